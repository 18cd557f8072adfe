"""The runs list at a lab's scale (issue 46): what the service does so that the list stays fast, checked by
its effect on answers and plans (the timings are benchmarks/bench_list_probe.py's and bench_lab_scale.py's).
"""

from __future__ import annotations

import gc
from pathlib import Path

import pytest
import sqlalchemy as sa
from alembic import command
from backend_helpers import BASE_URL, alembic_to, listing_statements
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, func, insert, select

from backend.api.app import create_app
from backend.errors import BadQuery
from backend.settings import Settings
from backend.store import crud, external
from backend.store.db import Database
from backend.store.models import JobSearch, JobSummary
from mgrao_core import make_spec


def test_the_api_leaves_its_start_up_objects_out_of_later_collections(tmp_path: Path) -> None:
    """Python's full collections walked every object the API imported, stalling every request (docs/service.md)."""
    gc.unfreeze()
    assert gc.get_freeze_count() == 0
    try:
        with TestClient(create_app(Settings(database_url=f"sqlite:///{tmp_path / 'm.db'}")), base_url=BASE_URL) as c:
            assert c.get("/api/jobs").status_code == 200
            assert gc.get_freeze_count() > 10_000  # the modules, the app and its routes
    finally:
        gc.unfreeze()  # the test process's objects collected as before


# ---- the search: one narrow row a job (models.JobSearch), the same answers -----------------------------------

LABELS = [  # (name, notes, tags)
    ("baseline sweep", "", ["paper", "lr"]),
    ("Ablation", "first line\nsecond LINE", []),
    ("rerun", "50% done_ok", ["Figure-3"]),
    ("draft", "", ["warm", "cold"]),
    ("", "sweep\n", ["x"]),
]
QUERIES = ["sweep", "SWEEP", "ablation", "line\nsecond", "line", "50%", "%", "_", "done_ok", "e_o", "figure-3",
           "warm", "warmcold", "warm\ncold", "sweep\nlr", "paper\nlr", "t\nr", "nothing", "\n"]


def _old_search(q: str) -> set[str]:
    """The jobs q found before the search row: a job whose name, notes or a tag holds q (any case)."""
    q = q.lower()
    return {name for name, notes, tags in LABELS
            if q in name.lower() or q in notes.lower() or any(q in t.lower() for t in tags)}


def _searched(db: Database, q: str) -> set[str]:
    with db.session() as session:
        jobs, _cursor, total = crud.list_jobs(session, q=q, limit=50)
    assert total == len(jobs)
    return {job["name"] for job in jobs}


def test_the_search_finds_in_names_notes_and_tags_what_it_found_before(db: Database) -> None:
    """q reads each job's search row (name, notes, tags joined by a newline): never a match across two of them."""
    spec = make_spec("single", seeds=1, episodes=5)
    with db.write() as session:
        crud.create_jobs(session, jobs=[{"spec": spec, "name": n, "notes": notes, "tags": tags}
                                        for n, notes, tags in LABELS[:2]])
        for name, notes, tags in LABELS[2:]:
            crud.create_job(session, spec=spec, name=name, notes=notes, tags=tags)
    for q in QUERIES:
        assert _searched(db, q) == _old_search(q), q


def test_an_edited_job_is_found_by_its_new_labels_only(db: Database) -> None:
    spec = make_spec("single", seeds=1, episodes=5)
    with db.write() as session:
        job_id = crud.create_job(session, spec=spec, name="old name", notes="old notes", tags=["old-tag"]).id
    with db.write() as session:
        crud.update_job(session, job_id=job_id, name="new name")
    assert _searched(db, "new name") == {"new name"} and _searched(db, "old name") == set()
    assert _searched(db, "old notes") == {"new name"} and _searched(db, "old-tag") == {"new name"}
    with db.write() as session:
        crud.update_job(session, job_id=job_id, notes="fresh", tags=["fresh-tag"])
    assert _searched(db, "old") == set()
    assert _searched(db, "fresh-tag") == {"new name"} and _searched(db, "fresh\nfresh") == set()
    with db.write() as session:
        crud.delete_job(session, job_id=job_id)
    with db.session() as session:
        assert session.scalar(select(func.count()).select_from(JobSearch)) == 0


def test_an_external_run_is_found_by_its_labels(db: Database) -> None:
    config = make_spec("single", seeds=1, episodes=1).as_dict() | {"algorithms": ["mine"]}
    with db.write() as session:
        external.open_run(session, config=config, name="outside", tags=["ext-tag"], notes="from a notebook",
                          open_key=None)
    assert _searched(db, "ext-tag") == _searched(db, "notebook") == {"outside"}


def test_the_migration_writes_the_search_rows_of_stored_jobs(db_url: str) -> None:
    """0019 fills job_search from every stored job's name, notes and tags; its downgrade drops it."""
    db = Database(db_url)
    db.migrate()
    try:
        spec = make_spec("single", seeds=1, episodes=5)
        with db.write() as session:
            for name, notes, tags in LABELS:
                crud.create_job(session, spec=spec, name=name, notes=notes, tags=tags)
        db.dispose()
        alembic_to(db_url, command.downgrade, "0017")
        engine = create_engine(db_url)
        assert "job_search" not in sa.inspect(engine).get_table_names()
        engine.dispose()
        db.migrate()
        for q in QUERIES:
            assert _searched(db, q) == _old_search(q), q
    finally:
        db.dispose()


# ---- sorts on a result: the rows with the value in index order, then those without ---------------------------

@pytest.mark.parametrize("descending", [False, True])
@pytest.mark.parametrize("column", ["final_mean", "pct_from_uniform", "pct_of_max"])
def test_a_result_sort_pages_in_the_order_of_value_is_null_value_id(db: Database, column: str,
                                                                    descending: bool) -> None:
    """Ties, nulls and jobs without the configuration's summary: every job once, in the order of before."""
    spec = make_spec("single", seeds=1, episodes=5)
    values = [3.0, None, 1.5, 3.0, "none", -2.0, None, 1.5, "none", 0.0, 3.0, None]  # "none": no summary row
    with db.write() as session:
        ids = [crud.create_job(session, spec=spec, name=f"j{i}").id for i in range(len(values))]
        session.execute(insert(JobSummary), [{"job_id": i, "algorithm": "mgrao-max", "n_runs": 1, column: v}
                                             for i, v in zip(ids, values, strict=True) if v != "none"]
                        + [{"job_id": i, "algorithm": "uniform", "n_runs": 1, column: 9.0} for i in ids])
    value = {i: (None if v == "none" else v) for i, v in zip(ids, values, strict=True)}
    valued = sorted((i for i in ids if value[i] is not None), key=lambda i: (value[i], i), reverse=descending)
    unvalued = sorted((i for i in ids if value[i] is None), reverse=descending)
    for limit in (1, 3, 4, 50):
        seen, cursor = [], None
        for _ in range(len(ids) + 2):
            with db.session() as session:
                jobs, cursor, total = crud.list_jobs(session, sort=f"{'-' if descending else ''}{column}:mgrao-max",
                                                     limit=limit, cursor=cursor)
            seen += [job["id"] for job in jobs]
            if cursor is None:
                break
        assert total == len(ids) and seen == valued + unvalued, (limit, seen)


# ---- the plans that keep a page at a lab's scale (docs/service.md, "The runs list at a lab's scale") ---------

def _page_plans(db: Database, containing: str = "ORDER BY", **listing) -> list[str]:
    """The database's plan of each statement with which crud.list_jobs reads a page (those ``containing``)."""
    seen = listing_statements(db, containing, **listing)
    plans = []
    with db.engine.connect() as connection:
        for statement, parameters in seen:
            if db.engine.dialect.name == "sqlite":
                rows = connection.exec_driver_sql(f"EXPLAIN QUERY PLAN {statement}", parameters).all()
                plans.append("\n".join(str(row[-1]) for row in rows))
            else:  # sorting and whole-table scans priced out: the index that gives the order is taken at any size
                connection.exec_driver_sql("SET enable_sort = off")
                connection.exec_driver_sql("SET enable_seqscan = off")
                plans.append("\n".join(row[0] for row in connection.exec_driver_sql(f"EXPLAIN {statement}",
                                                                                  parameters).all()))
    return plans


@pytest.fixture
def many_jobs(db: Database) -> Database:
    """40 jobs of two systems, most with summaries, one in five without."""
    with db.write() as session:
        for i in range(40):
            spec = make_spec("single" if i % 2 else "multi", seeds=1, episodes=5)
            job = crud.create_job(session, spec=spec, name=f"job {i}")
            if i % 5:
                session.execute(insert(JobSummary), [{"job_id": job.id, "algorithm": "mgrao-max", "n_runs": 1,
                                                      "final_mean": i / 3, "pct_from_uniform": i / 7,
                                                      "pct_of_max": i / 11}])
    return db


@pytest.mark.parametrize("sort", ["-pct_of_max:mgrao-max", "final_mean:mgrao-max", "-pct_from_uniform:mgrao-max"])
def test_a_page_by_a_result_reads_its_summaries_index_in_order(many_jobs: Database, sort: str) -> None:
    """The jobs with the value are read from (algorithm, value, job_id) and the page stops: no sort of every
    summary for each page (the null-last term made one); a page that reaches the jobs without it reads ids."""
    column = sort.lstrip("-").split(":")[0]
    index = {"final_mean": "ix_job_summaries_final", "pct_from_uniform": "ix_job_summaries_pct",
             "pct_of_max": "ix_job_summaries_max"}[column]
    with many_jobs.session() as session:
        _jobs, cursor, _total = crud.list_jobs(session, sort=sort, limit=5)
    for listing in ({"sort": sort, "limit": 5}, {"sort": sort, "limit": 5, "cursor": cursor},
                    {"sort": sort, "limit": 45}):
        plans = _page_plans(many_jobs, **listing)
        valued = plans[0]
        if many_jobs.engine.dialect.name == "sqlite":
            assert "TEMP B-TREE" not in valued and index in valued, (listing, valued)
        else:
            assert "Sort" not in valued and index in valued, (listing, valued)
    assert len(plans) == 2  # the whole listing: the valued part, then the others


def test_a_systems_page_reads_its_index_in_order(many_jobs: Database) -> None:
    """A system's newest jobs from (system, created_at, id): not every job of the system sorted for each page."""
    for system in ("multi", "single"):
        with many_jobs.session() as session:
            _jobs, cursor, _total = crud.list_jobs(session, system=system, limit=5)
        for listing in ({"system": system, "limit": 5}, {"system": system, "limit": 5, "cursor": cursor}):
            (text,) = _page_plans(many_jobs, **listing)
            if many_jobs.engine.dialect.name == "sqlite":
                assert "TEMP B-TREE" not in text and "ix_jobs_system_created" in text, (listing, text)
            else:
                assert "Sort" not in text and "ix_jobs_system_created" in text, (listing, text)


def test_a_count_of_a_systems_jobs_of_one_status_reads_no_jobs_row(many_jobs: Database) -> None:
    """(system, created_at, id, status): the count of a filtered listing reads the index alone (SQLite)."""
    (text,) = _page_plans(many_jobs, containing="count(*)", system="multi", status="queued", limit=5)
    if many_jobs.engine.dialect.name == "sqlite":  # PostgreSQL's index-only scans depend on its visibility map
        assert "COVERING INDEX ix_jobs_system_created" in text, text


def test_a_search_reads_the_narrow_search_rows(many_jobs: Database) -> None:
    """q reads job_search (tens of bytes a job), not every job's row (its configuration: kilobytes)."""
    (text,) = _page_plans(many_jobs, q="job 1", limit=5)
    assert "job_search" in text, text


def test_a_search_of_many_matches_reads_the_jobs_in_the_pages_order(db: Database) -> None:
    """Beyond crud.SEARCH_FEW matches a search's page reads the order's index and checks each job's search row,
    stopping when the page is full, instead of reading every match and sorting them; the same jobs either way."""
    spec, n = make_spec("single", seeds=1, episodes=5), 3 * crud.SEARCH_FEW // 2 + 3
    with db.write() as session:  # one statement: one created_at, so the newest first is the highest id first
        crud.create_jobs(session, jobs=[{"spec": spec, "name": f"common {i}" if i % 3 else f"rare {i}"}
                                        for i in range(n)])
    for q, many in (("common", True), ("rare", False)):
        if db.engine.dialect.name == "sqlite":  # PostgreSQL's planner picks either way for both forms of the query
            (text,) = _page_plans(db, q=q, limit=5)
            assert ("TEMP B-TREE" not in text and "ix_jobs_created" in text) == many, (q, text)
        with db.session() as session:
            jobs, cursor, total = crud.list_jobs(session, q=q, limit=5)
            again, _cursor, _total = crud.list_jobs(session, q=q, limit=5, cursor=cursor)
        assert total > crud.SEARCH_FEW if many else total < crud.SEARCH_FEW
        expected = [job_id for job_id in range(n, 0, -1) if ((job_id - 1) % 3 != 0) == many]
        assert [job["id"] for job in jobs + again] == expected[:10], q


def test_a_search_that_finds_nothing_still_checks_its_cursor(db: Database) -> None:
    with db.session() as session:
        assert crud.list_jobs(session, q="nothing")[2] == 0
        with pytest.raises(BadQuery) as raised:
            crud.list_jobs(session, q="nothing", cursor="bm90IGEgY3Vyc29y")
    assert "cursor" in str(raised.value)
