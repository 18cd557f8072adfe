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
from alembic import command
from sqlalchemy import create_engine, select, text

from backend.crud import config_hash
from backend.db import Database, alembic_config
from backend.models import Job, Run
from backend.worker import Worker
from mgrao_core import make_spec
from tests.backend.backend_helpers import drain

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "legacy_jobs_0001.json"
LEGACY = json.loads(FIXTURE.read_text())


def _database_at_0001(url: str) -> None:
    """A database with revision 0001's schema, holding the legacy jobs, queued, as 0001 stored them."""
    engine = create_engine(url)
    config = alembic_config()
    with engine.connect() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "0001")
        for job in LEGACY["jobs"]:
            connection.execute(
                text("INSERT INTO jobs (name, tags, notes, system, config, config_hash, status, progress, attempts,"
                     " version, created_at) VALUES ('legacy', '[]', '', :system, :config, :hash, 'queued', 0, 0,"
                     " '0.1.0', :created)"),
                {"system": job["config"]["system"], "config": json.dumps(job["config"]), "hash": job["config_hash"],
                 "created": datetime(2026, 11, 1)},
            )
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
        rows = connection.execute(text("SELECT config, config_hash FROM jobs ORDER BY id")).all()
    engine.dispose()
    db.dispose()
    for (config, digest), legacy in zip(rows, LEGACY["jobs"], strict=True):
        assert json.loads(config) == legacy["config"]
        assert digest == legacy["config_hash"]


def test_upgrade_leaves_configurations_that_name_a_reading_and_downgrade_keeps_other_readings(tmp_path, settings):
    _database_at_0001(settings.database_url)
    engine = create_engine(settings.database_url)
    new_reading = make_spec("single", seeds=2, episodes=5, overrides={"quality_model": "exponential"}).as_dict()
    first = {"quality_model": "relative-linear", "routing": "per-task", "half_saturation": 0.5}
    odd_h = make_spec("single", seeds=2, episodes=5, overrides=first).as_dict()
    with engine.begin() as connection:
        for config in (new_reading, odd_h):
            connection.execute(
                text("INSERT INTO jobs (name, tags, notes, system, config, config_hash, status, progress, attempts,"
                     " version, created_at) VALUES ('x', '[]', '', 'single', :config, :hash, 'queued', 0, 0,"
                     " '0.2.0', :created)"),
                {"config": json.dumps(config), "hash": config_hash(config), "created": datetime(2026, 11, 2)})
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
        rows = [json.loads(c) for (c,) in connection.execute(text("SELECT config FROM jobs ORDER BY id"))]
    engine.dispose()
    db.dispose()
    assert rows[-2]["params"]["quality_model"] == "exponential"  # not expressible at 0001: kept
    assert "quality_model" not in rows[-1]["params"]  # the first reading, whatever its unused h
