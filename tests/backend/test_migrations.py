"""Schema and data migrations on real SQLite files: old jobs keep meaning what they meant.

``tests/fixtures/legacy_jobs_0001.json`` holds jobs as the service stored them at revision 0001
(commit c643684, before the environment readings existed) with the utilities that version
computed for them, written as exact float hex.
"""

from __future__ import annotations

import json
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa
from alembic import command
from alembic.script import ScriptDirectory
from sqlalchemy import create_engine, select, text

from backend.execution.worker import Worker
from backend.store import crud
from backend.store.crud import config_hash
from backend.store.db import Database, alembic_config
from backend.store.models import Job, Run
from mgrao_core import make_spec
from tests.backend.backend_helpers import alembic_to, drain

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "legacy_jobs_0001.json"
LEGACY = json.loads(FIXTURE.read_text())
HEAD = ScriptDirectory.from_config(alembic_config()).get_current_head()

pytestmark = pytest.mark.empty_database  # db_url without a schema: these tests migrate it themselves


JOBS_0001 = sa.table(
    "jobs", sa.column("name", sa.String), sa.column("tags", sa.JSON), sa.column("notes", sa.Text),
    sa.column("system", sa.String), sa.column("config", sa.JSON), sa.column("config_hash", sa.String),
    sa.column("status", sa.String), sa.column("progress", sa.Float), sa.column("attempts", sa.Integer),
    sa.column("version", sa.String), sa.column("created_at", sa.DateTime),
)


def _insert_job(connection, config: dict, digest: str, name: str, created: datetime) -> None:
    """A queued job row exactly as revision 0001's code wrote it."""
    connection.execute(JOBS_0001.insert().values(
        name=name, tags=[], notes="", system=config["system"], config=config, config_hash=digest, status="queued",
        progress=0.0, attempts=0, version="0.1.0", created_at=created))


def _database_at_0001(url: str) -> None:
    """A database with revision 0001's schema, holding the legacy jobs, queued, as 0001 stored them."""
    engine = create_engine(url)
    config = alembic_config()
    with engine.connect() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "0001")
        for job in LEGACY["jobs"]:
            _insert_job(connection, job["config"], job["config_hash"], "legacy", datetime(2026, 11, 1))
        connection.commit()
    engine.dispose()


@pytest.fixture
def migrated(tmp_path, settings):
    _database_at_0001(settings.database_url)
    db = Database(settings.database_url)
    db.migrate()
    yield db
    db.dispose()


def test_migration_writes_the_first_reading_into_every_stored_configuration(migrated):
    with migrated.session() as session:
        jobs = session.scalars(select(Job).order_by(Job.id)).all()
        version = session.execute(text("SELECT version_num FROM alembic_version")).scalar()
    assert version >= "0002"
    assert len(jobs) == len(LEGACY["jobs"])
    for job, legacy in zip(jobs, LEGACY["jobs"], strict=True):
        params = job.config["params"]
        assert params["quality_model"] == "relative-linear"
        assert params["routing"] == "per-task"
        assert params["load_sharing"] is False
        assert params["absent_tasks"] == "excluded"
        assert {k: v for k, v in params.items() if k in legacy["config"]["params"]} == legacy["config"]["params"]
        assert job.config_hash == config_hash(job.config) != legacy["config_hash"]


def test_migrated_jobs_rerun_bit_identically_and_never_pool_with_the_new_default(migrated, settings):
    worker = Worker(settings, worker_id="migration-test")
    try:
        assert drain(worker) == len(LEGACY["jobs"])
    finally:
        worker.db.dispose()
    with migrated.session() as session:
        jobs = session.scalars(select(Job).order_by(Job.id)).all()
        runs = {(r.job_id, r.algorithm, r.seed): r for r in session.scalars(select(Run)).all()}
    compared = 0
    for job, legacy in zip(jobs, LEGACY["jobs"], strict=True):
        assert job.status == "succeeded", job.error
        for old in legacy["runs"]:
            stored = runs[(job.id, old["algorithm"], old["seed"])]
            expected = np.array([float.fromhex(x) for x in old["utilities"]])
            assert np.frombuffer(stored.utilities, dtype="<f8").tobytes() == expected.astype("<f8").tobytes()
            weights = np.array([float.fromhex(x) for x in old["combined_weights"]])
            np.testing.assert_array_equal(np.frombuffer(stored.combined_weights, dtype="<f8"), weights)
            compared += 1
        # the same experiment submitted today runs the new default reading: another configuration
        config = job.config
        today = make_spec(config["system"], config["algorithms"], config["seeds"], config["episodes"]).as_dict()
        assert config_hash(today) != job.config_hash
    assert compared == sum(len(j["runs"]) for j in LEGACY["jobs"])


def test_downgrade_restores_revision_0001_configurations(tmp_path, settings):
    _database_at_0001(settings.database_url)
    db = Database(settings.database_url)
    db.migrate()
    engine = create_engine(settings.database_url)
    config = alembic_config()
    with engine.connect() as connection:
        config.attributes["connection"] = connection
        command.downgrade(config, "0001")
        connection.commit()
        rows = connection.execute(sa.select(JOBS_0001.c.config, JOBS_0001.c.config_hash).order_by(sa.text("id"))).all()
    engine.dispose()
    db.dispose()
    for (config, digest), legacy in zip(rows, LEGACY["jobs"], strict=True):
        assert config == legacy["config"]
        assert digest == legacy["config_hash"]


def test_upgrade_leaves_configurations_that_name_a_reading_and_downgrade_keeps_other_readings(tmp_path, settings):
    _database_at_0001(settings.database_url)
    engine = create_engine(settings.database_url)
    new_reading = make_spec("single", seeds=2, episodes=5, overrides={"quality_model": "exponential"}).as_dict()
    first = {"quality_model": "relative-linear", "routing": "per-task", "half_saturation": 0.5}
    odd_h = make_spec("single", seeds=2, episodes=5, overrides=first).as_dict()
    with engine.begin() as connection:
        for config in (new_reading, odd_h):
            _insert_job(connection, config, config_hash(config), "x", datetime(2026, 11, 2))
    db = Database(settings.database_url)
    db.migrate()
    with db.session() as session:
        stored = session.scalars(select(Job).order_by(Job.id)).all()[-2:]
        assert stored[0].config == new_reading and stored[1].config == odd_h  # untouched by the upgrade
    config = alembic_config()
    with engine.connect() as connection:
        config.attributes["connection"] = connection
        command.downgrade(config, "0001")
        connection.commit()
        rows = [c for (c,) in connection.execute(sa.select(JOBS_0001.c.config).order_by(sa.text("id")))]
    engine.dispose()
    db.dispose()
    assert rows[-2]["params"]["quality_model"] == "exponential"  # not expressible at 0001: kept
    assert "quality_model" not in rows[-1]["params"]  # the first reading, whatever its unused h


def test_processes_that_start_together_migrate_a_new_database_once(db_url: str) -> None:
    # a server and its workers all migrate at start: on a fresh database they must not collide
    import subprocess
    import sys

    # (SQLite once raced here about one time in ten: Alembic committed step by step; three rounds of
    # six processes each, on fresh files)
    code = "import sys; from backend.store.db import Database; d = Database(sys.argv[1]); d.migrate(); d.dispose()"
    urls = [db_url] + ([db_url.replace(".db", f"-{i}.db") for i in range(2)] if db_url.startswith("sqlite") else [])
    for url in urls:
        processes = [subprocess.Popen([sys.executable, "-c", code, url], stderr=subprocess.PIPE) for _ in range(6)]
        errors = [p.communicate(timeout=120)[1].decode() for p in processes]
        assert [p.returncode for p in processes] == [0] * 6, errors
        db = Database(url)
        try:
            with db.session() as session:
                assert session.execute(text("SELECT count(*) FROM alembic_version")).scalar() == 1
                assert session.execute(text("SELECT version_num FROM alembic_version")).scalar() == HEAD
        finally:
            db.dispose()


def test_rebuilding_jobs_for_ids_keeps_every_run_and_tag_and_their_cascades(settings, db_url: str) -> None:
    engine = create_engine(db_url)
    config = alembic_config()
    with engine.connect() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "0003")
        connection.commit()
    with engine.begin() as connection:
        for i in range(3):
            _insert_job(connection, LEGACY["jobs"][0]["config"], LEGACY["jobs"][0]["config_hash"], f"j{i}",
                        datetime(2026, 11, 3))
        connection.execute(text("INSERT INTO job_tags (job_id, tag) VALUES (1, 'a'), (2, 'b'), (3, 'c')"))
        for job_id in (1, 2, 3):
            connection.execute(text(
                "INSERT INTO runs (job_id, algorithm, seed, episodes, utilities, combined_weights, group_weights,"
                " group_shape) VALUES (:j, 'uniform', 0, 1, :u, :u, :u, '[1, 0, 20]')"), {"j": job_id, "u": b"x" * 8})
    engine.dispose()
    db = Database(db_url)
    db.migrate()
    try:
        with db.session() as session:
            assert session.execute(text("SELECT count(*) FROM runs")).scalar() == 3
            assert session.execute(text("SELECT count(*) FROM job_tags")).scalar() == 3
        with db.write() as session:
            crud.delete_job(session, job_id=3)
        with db.session() as session:  # the cascade still reaches the runs and tags
            assert session.execute(text("SELECT count(*) FROM runs")).scalar() == 2
            assert session.execute(text("SELECT count(*) FROM job_tags")).scalar() == 2
        with db.write() as session:
            new = crud.create_job(session, spec=make_spec("single", seeds=1, episodes=2)).id
        assert new == 4  # not 3
    finally:
        db.dispose()


def test_jobs_that_succeeded_before_summaries_were_stored_get_them_from_their_runs(settings, db_url, client, worker):
    from backend.store import summaries
    from backend.store.models import JobSummary

    for rate in (0.1, 0.3):
        body = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3, "episodes": 12,
                "params": {"learning_rate": rate}}
        assert client.post("/api/jobs", json=body).status_code == 202
    assert drain(worker) == 2
    db = Database(db_url)
    try:
        with db.session() as session:
            written = {(r.job_id, r.algorithm): r.final_mean for r in session.scalars(select(JobSummary))}
        assert len(written) == 4
        engine = create_engine(db_url)
        config = alembic_config()
        with engine.connect() as connection:  # back to 0006: succeeded jobs, no summaries
            config.attributes["connection"] = connection
            command.downgrade(config, "0006")
            connection.commit()
            assert connection.execute(text("SELECT count(*) FROM job_summaries")).scalar() == 0
        engine.dispose()
        db.migrate()
        with db.session() as session:
            backfilled = {(r.job_id, r.algorithm): r.final_mean for r in session.scalars(select(JobSummary))}
            assert backfilled == written
            assert summaries.compute(session, 1)["mgrao-max"].final_mean == written[(1, "mgrao-max")]
    finally:
        db.dispose()


def test_jobs_stored_before_external_runs_are_simulations_and_downgrade_drops_external_runs(db_url: str) -> None:
    alembic_to(db_url, command.upgrade, "0008")
    engine = create_engine(db_url)
    with engine.begin() as connection:
        _insert_job(connection, LEGACY["jobs"][0]["config"], LEGACY["jobs"][0]["config_hash"], "old",
                    datetime(2026, 11, 3))
    engine.dispose()
    db = Database(db_url)
    db.migrate()
    try:
        with db.session() as session:
            assert session.execute(text("SELECT kind FROM jobs")).scalars().all() == ["simulation"]
        from backend.store import external

        config = make_spec("single", seeds=1, episodes=1).as_dict() | {"algorithms": ["mine"]}
        with db.write() as session:
            job, created = external.open_run(session, config=config, name="", tags=["t"], notes="", open_key="k")
            external.append_batch(session, job_id=job.id, key="b", digest="d",
                                  pieces=[external.Piece(0, 0, np.array([1.0]))], weights=[])
        assert created and job.kind == "external"
        alembic_to(db_url, command.downgrade, "0008")  # the external run goes: no earlier revision tells it apart
        with db.session() as session:
            assert session.execute(text("SELECT name FROM jobs")).scalars().all() == ["old"]
            assert session.execute(text("SELECT count(*) FROM runs")).scalar() == 0
            assert session.execute(text("SELECT count(*) FROM job_tags")).scalar() == 0
            tables = sa.inspect(session.get_bind()).get_table_names()
        assert not {"external_runs", "external_batches", "external_pieces"} & set(tables)
        db.dispose()
        db.migrate()
        with db.session() as session:
            assert session.execute(text("SELECT kind FROM jobs")).scalars().all() == ["simulation"]
    finally:
        db.dispose()


def test_saved_systems_table_comes_with_0011_and_goes_on_downgrade(db_url: str) -> None:
    db = Database(db_url)
    db.migrate()
    try:
        from backend.services import saved_systems

        with db.write() as session:
            saved_systems.create_saved(session, name="mine", description="d", base="single",
                                       params={"n_parents": 12})
        with db.session() as session:
            assert [s.params for s in saved_systems.list_saved(session)] == [{"n_parents": 12}]
        db.dispose()
        alembic_to(db_url, command.downgrade, "0010")
        engine = create_engine(db_url)
        assert "saved_systems" not in sa.inspect(engine).get_table_names()
        engine.dispose()
        db.migrate()
        with db.session() as session:
            assert saved_systems.list_saved(session) == []
    finally:
        db.dispose()


def test_summaries_stored_before_0013_get_the_seeds_their_paired_figures_stand_on(db_url, client, worker) -> None:
    job = client.post("/api/jobs", json={"system": "single", "seeds": 3, "episodes": 10,
                                         "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"]}).json()
    assert drain(worker) == 1
    engine = create_engine(db_url)
    with engine.begin() as connection:  # as 0012 stored it: no pairing counts, one run of uniform gone
        connection.execute(text("DELETE FROM runs WHERE algorithm = 'uniform' AND seed = 2"))
    engine.dispose()
    alembic_to(db_url, command.downgrade, "0012")
    alembic_to(db_url, command.upgrade, "0013")
    with create_engine(db_url).connect() as connection:
        rows = connection.execute(text("SELECT algorithm, n_runs, n_paired, n_paired_max FROM job_summaries "
                                       "WHERE job_id = :id ORDER BY algorithm"), {"id": job["id"]}).all()
    assert [tuple(r) for r in rows] == [("mgrao-1:1", 3, 2, 2), ("mgrao-max", 3, 2, 2), ("uniform", 3, 2, 2)]


def test_runs_and_summaries_stored_before_0015_count_no_tasks_and_answer_rates_of_0(settings, db_url: str) -> None:
    from fastapi.testclient import TestClient

    from backend.api.app import create_app
    from tests.backend.backend_helpers import BASE_URL

    alembic_to(db_url, command.upgrade, "0014")
    config = make_spec("single", ["uniform"], seeds=1, episodes=1).as_dict()
    blob = np.array([1.5]).tobytes()
    engine = create_engine(db_url)
    with engine.begin() as connection:  # a succeeded job, its run and its summary as 0014 stored them
        _insert_job(connection, config, config_hash(config), "old", datetime(2026, 11, 26))
        connection.execute(text("UPDATE jobs SET status = 'succeeded'"))
        connection.execute(text(
            "INSERT INTO runs (job_id, algorithm, seed, episodes, utilities, combined_weights, group_weights,"
            " group_shape) VALUES (1, 'uniform', 0, 1, :u, :u, :u, '[1, 0, 20]')"), {"u": blob})
        connection.execute(text("INSERT INTO job_summaries (job_id, algorithm, n_runs, final_mean, n_paired) "
                                "VALUES (1, 'uniform', 1, 1.5, 1)"))
    engine.dispose()
    counts = "SELECT tasks_allocated, tasks_failed, tasks_handed_over FROM "
    db = Database(db_url)
    db.migrate()
    try:
        with db.session() as session:
            assert [tuple(r) for r in session.execute(text(counts + "runs"))] == [(0, 0, 0)]
            assert [tuple(r) for r in session.execute(text(counts + "job_summaries"))] == [(0, 0, 0)]
        with TestClient(create_app(settings), base_url=BASE_URL) as client:
            rates = {"failure_rate": 0.0, "handover_rate": 0.0}
            assert client.get("/api/jobs/1").json()["summaries"]["uniform"].items() >= rates.items()
            assert client.get("/api/jobs/1/results").json()["configurations"][0]["summary"].items() >= rates.items()
            assert client.get("/api/compare?jobs=1").json()["groups"][0]["summary"].items() >= rates.items()
        db.dispose()
        alembic_to(db_url, command.downgrade, "0014")  # the counts go; the run and its summary stay
        engine = create_engine(db_url)
        with engine.connect() as connection:
            assert "tasks_failed" not in {c["name"] for c in sa.inspect(connection).get_columns("runs")}
            assert connection.execute(text("SELECT count(*) FROM runs")).scalar() == 1
        engine.dispose()
    finally:
        db.dispose()


SUMMARIES_0015 = json.loads((FIXTURE.parent / "legacy_summaries_0015.json").read_text())
"""Finished jobs whose summaries were stored with the t table (tests/fixtures/make_legacy_summaries_0015.py)."""
FIGURES = ("n_runs", "final_mean", "final_low", "final_high", "pct_from_uniform", "pct_low", "pct_high", "pct_of_max",
           "n_paired", "n_paired_max")
JOBS_0015 = sa.table("jobs", *(sa.column(name) for name in (
    "name", "tags", "notes", "system", "config", "config_hash", "status", "progress", "attempts", "version",
    "created_at", "started_at", "finished_at")))
JOBS_0015.c.config.type = sa.JSON()
JOBS_0015.c.tags.type = sa.JSON()
RUNS_0015 = sa.table("runs", *(sa.column(name) for name in (
    "job_id", "algorithm", "seed", "episodes", "utilities", "combined_weights", "group_weights", "group_shape")))
RUNS_0015.c.group_shape.type = sa.JSON()
SUMMARIES_TABLE = sa.table("job_summaries", sa.column("job_id"), sa.column("algorithm"),
                           *(sa.column(name) for name in FIGURES))


def _figure(value: str | int | None) -> float | int | None:
    return float.fromhex(value) if isinstance(value, str) else value


def _store_as_0015(db_url: str) -> list[int]:
    """The fixture's jobs at revision 0015: succeeded, their runs, and their summaries as the t table made them."""
    alembic_to(db_url, command.upgrade, "0015")
    engine = create_engine(db_url)
    ids = []
    with engine.begin() as connection:
        for job in SUMMARIES_0015["jobs"]:
            config = job["config"]
            when = datetime(2026, 11, 20)
            job_id = connection.execute(JOBS_0015.insert().values(
                name="stored with the t table", tags=[], notes="", system=config["system"], config=config,
                config_hash=job["config_hash"], status="succeeded", progress=1.0, attempts=1, version="0.1.0",
                created_at=when, started_at=when, finished_at=when).returning(sa.literal_column("id"))).scalar()
            ids.append(job_id)
            params = config["params"]
            connection.execute(RUNS_0015.insert(), [{
                "job_id": job_id, "algorithm": run["algorithm"], "seed": run["seed"],
                "episodes": len(run["utilities"]),
                "utilities": np.array([float.fromhex(v) for v in run["utilities"]], dtype="<f8").tobytes(),
                "combined_weights": b"", "group_weights": b"",  # summaries stand on the utilities alone
                "group_shape": [params["n_children"], 0, params["n_types"]]} for run in job["runs"]])
            connection.execute(SUMMARIES_TABLE.insert(), [
                {"job_id": job_id, "algorithm": algorithm} | {k: _figure(v) for k, v in row.items()}
                for algorithm, row in job["legacy"].items()])
    engine.dispose()
    return ids


def _interval(summary: dict) -> tuple:
    return summary["final_mean"], tuple(summary["ci95"]), summary["pct_from_uniform"], summary["pct_ci95"] and tuple(
        summary["pct_ci95"]), summary["pct_of_max"]


def test_summaries_stored_with_the_t_table_show_the_interval_their_results_and_a_new_identical_job_show(
        service, db_url: str) -> None:
    ids = _store_as_0015(db_url)
    service.start_server(workers=0)  # `mgrao serve` migrates the database to the head: 0016 recomputes them
    listed = {job["id"]: job["summaries"] for job in service.get("/api/jobs?limit=200").json()["data"]}
    changed = 0
    for job_id, job in zip(ids, SUMMARIES_0015["jobs"], strict=True):
        record = service.get(f"/api/jobs/{job_id}").json()["summaries"]
        results = {c["algorithm"]: c["summary"] for c in service.get(f"/api/jobs/{job_id}/results").json()[
            "configurations"]}
        assert set(record) == set(results) == set(listed[job_id]) == set(job["current"])
        for algorithm, now in job["current"].items():
            one = _interval(record[algorithm])
            assert one == _interval(results[algorithm]) == _interval(listed[job_id][algorithm]), algorithm
            expected = {k: _figure(v) for k, v in now.items()}
            # today's figures, as the fixture recorded them: if this fails, how a summary is computed changed, and
            # the summaries stored before need a migration that recomputes them, as 0016 does
            shown = {k: record[algorithm][k] for k in ("final_mean", "pct_from_uniform", "pct_of_max", "n_paired",
                                                       "n_paired_max", "n_runs")}
            shown |= dict(zip(("final_low", "final_high"), record[algorithm]["ci95"], strict=True))
            shown |= dict(zip(("pct_low", "pct_high"), record[algorithm]["pct_ci95"] or [None, None], strict=True))
            assert shown == expected, (f"job {job_id} {algorithm}: a summary is no longer computed as when the "
                                       "fixture was made; the summaries stored before need a migration that "
                                       "recomputes them, as 0016 does (docs/service.md, 'One interval per "
                                       "experiment'), and the fixture's 'current' figures remade")
            changed += record[algorithm]["ci95"] != [_figure(job["legacy"][algorithm][k])
                                                     for k in ("final_low", "final_high")]
    assert changed >= 6  # the table's intervals are gone (the one-seed job has none)

    service.start_worker()  # the same experiment submitted today stores the same summaries
    first = SUMMARIES_0015["jobs"][0]["config"]
    body = {k: first[k] for k in ("system", "algorithms", "seeds", "episodes")}
    new = service.post("/api/jobs", json=body).json()["id"]
    service.wait_for(lambda: service.get(f"/api/jobs/{new}").json()["status"] == "succeeded", timeout=300,
                     what="the identical job")
    listed = {job["id"]: job["summaries"] for job in service.get("/api/jobs?limit=200").json()["data"]}
    assert service.get(f"/api/jobs/{new}").json()["config_hash"] == SUMMARIES_0015["jobs"][0]["config_hash"]
    assert {a: _interval(s) for a, s in listed[new].items()} == {a: _interval(s) for a, s in listed[ids[0]].items()}


@pytest.mark.parametrize("path", ["alone", "in a batch"])
def test_a_job_on_seeds_out_of_order_stores_the_summary_its_results_show(service, path: str) -> None:
    # a mean's last bits depend on its seeds' order: the stored summary takes them in the job's order, as the
    # results do (SQLite read them back in ascending order: uniform's mean here differed in its last bit)
    if path == "alone":
        service.env["MGRAO_SMALL_JOB_WORK"] = "0"  # no job is small: each is claimed, run and finished alone
    service.start_server(workers=1)
    job = SUMMARIES_0015["jobs"][2]["config"]
    assert job["seeds"] == [7, 2, 9, 4, 0]
    job_id = service.post("/api/jobs", json={k: job[k] for k in ("system", "algorithms", "seeds", "episodes")}).json()[
        "id"]
    service.wait_for(lambda: service.get(f"/api/jobs/{job_id}").json()["status"] == "succeeded", timeout=300,
                     what="the job")
    record = service.get(f"/api/jobs/{job_id}").json()["summaries"]
    results = {c["algorithm"]: c["summary"] for c in service.get(f"/api/jobs/{job_id}/results").json()[
        "configurations"]}
    assert {a: _interval(s) for a, s in record.items()} == {a: _interval(s) for a, s in results.items()}
    assert record["uniform"]["final_mean"] == float.fromhex(SUMMARIES_0015["jobs"][2]["current"]["uniform"][
        "final_mean"])
