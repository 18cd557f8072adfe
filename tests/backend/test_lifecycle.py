"""The job lifecycle shared by the local worker and the Dask dispatcher: one error mapping, one "ended" hook.

The studies advance through that hook alone here: no API process runs (so no study driver), and a
study finishes only if each process that ran its jobs told it that they ended. Real SQLite files,
real ``mgrao worker`` and ``mgrao dispatcher`` processes, a real local Dask cluster.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from sqlalchemy import select, update

from backend.execution.failures import Failure, failure
from backend.execution.worker import Worker
from backend.services import studies
from backend.settings import Settings
from backend.store import crud
from backend.store.db import Database
from backend.store.models import FAILED, Job, Study
from mgrao_core import ConfigError, MgraoError, NumericalError, make_spec, spec_from_dict
from mgrao_core.search import make_plan
from tests.support.dask_cluster import DaskCluster
from tests.support.local_service import mgrao_command, stop
from tests.support.waiting import wait_until

FAST = {"MGRAO_POLL_S": "0.1", "MGRAO_HEARTBEAT_S": "0.5", "MGRAO_PROGRESS_S": "0.2", "MGRAO_STALE_AFTER_S": "4"}
STUDY = {
    "name": "three cells, one at a time", "method": "grid",
    "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 15},
    "space": {"learning_rate": {"low": 0.05, "high": 0.2, "steps": 3}},
    "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform", "direction": "maximize"},
    "max_trials": 3, "max_in_flight": 1,
}
BAD_CONFIG = {"system": "single", "algorithms": ["uniform"], "seeds": [1], "episodes": 0}


@pytest.fixture
def sqlite_db(tmp_path: Path) -> Iterator[Database]:
    database = Database(f"sqlite:///{tmp_path / 'mgrao.db'}")
    database.migrate()
    yield database
    database.dispose()


def _bad_job(db: Database) -> int:
    """A queued job whose stored configuration no longer validates (as after a change of the core's limits)."""
    with db.write() as session:
        job_id = crud.create_job(session, spec=make_spec("single", seeds=1, episodes=5)).id
        session.execute(update(Job).where(Job.id == job_id).values(config=BAD_CONFIG))
    return job_id


def _expected_error() -> str:
    with pytest.raises(MgraoError) as raised:
        spec_from_dict(BAD_CONFIG)
    return failure(raised.value).message


def _study_status(db: Database, study_id: int) -> str:
    with db.session() as session:
        return session.scalar(select(Study.status).where(Study.id == study_id))


def _job(db: Database, job_id: int) -> Job:
    with db.session() as session:
        return session.get(Job, job_id)


def test_one_mapping_turns_what_a_job_raised_into_its_failure() -> None:
    assert failure(NumericalError("utilities are not finite")) == Failure("utilities are not finite", True)
    assert failure(ConfigError("episodes", "must be at least 1")) == Failure(
        "episodes: must be at least 1")
    assert failure(ZeroDivisionError("division by zero"), where="chunk 2 (seeds 4..5) failed: ") == Failure(
        "chunk 2 (seeds 4..5) failed: ZeroDivisionError: division by zero")


def test_job_execution_imports_no_study() -> None:
    code = ("import sys, backend.execution.worker, backend.execution.dispatcher, backend.execution.lifecycle; "
            "assert not [m for m in sys.modules if m.startswith('backend.services')], sorted(sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_worker_process_imports_no_migrations() -> None:
    """A worker reads and writes the store but never migrates it: Alembic is imported by migrating alone (about a
    fifth of a CPU-second of each worker process's start)."""
    code = ("import sys, backend.processes; "
            "assert not [m for m in sys.modules if m.split('.')[0] == 'alembic'], sorted(sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=60)


def test_a_worker_without_subscribers_leaves_the_study_to_the_driver(sqlite_db: Database, tmp_path: Path) -> None:
    study_id = studies.create_study(sqlite_db, plan=make_plan(STUDY))
    worker = Worker(Settings(database_url=f"sqlite:///{tmp_path / 'mgrao.db'}"), worker_id="bare")
    try:
        assert worker.run_once()
        assert not worker.run_once()  # the next cell is made only when the study advances
    finally:
        worker.db.dispose()
    studies.advance(sqlite_db, study_id)  # what the API's study driver does every few seconds
    with sqlite_db.session() as session:
        assert session.scalar(select(Job.id).where(Job.study_id == study_id, Job.status == "queued")) is not None


def test_a_worker_process_fails_a_bad_job_by_the_mapping_and_advances_a_study_as_its_jobs_end(
        sqlite_db: Database, tmp_path: Path) -> None:
    bad = _bad_job(sqlite_db)
    study_id = studies.create_study(sqlite_db, plan=make_plan(STUDY))
    env = dict(os.environ, MGRAO_DATABASE_URL=f"sqlite:///{tmp_path / 'mgrao.db'}", **FAST)
    with open(tmp_path / "worker.log", "wb") as log:
        process = subprocess.Popen(mgrao_command("worker"), env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        wait_until(lambda: _study_status(sqlite_db, study_id) == "finished", 240, "the study, advanced by the worker",
                   details=lambda: (tmp_path / "worker.log").read_text(errors="replace")[-3000:])
    finally:
        stop(process)
    job = _job(sqlite_db, bad)
    assert (job.status, job.error) == (FAILED, _expected_error())


@pytest.mark.slow
def test_the_dispatcher_fails_a_bad_job_by_the_mapping_and_advances_a_study_as_its_jobs_end(
        sqlite_db: Database, tmp_path: Path) -> None:
    cluster = DaskCluster(tmp_path)
    cluster.start_scheduler()
    dispatcher = None
    try:
        cluster.start_worker()
        cluster.wait_workers(1)
        bad = _bad_job(sqlite_db)
        study_id = studies.create_study(sqlite_db, plan=make_plan(STUDY))
        env = dict(os.environ, MGRAO_DATABASE_URL=f"sqlite:///{tmp_path / 'mgrao.db'}", **FAST)
        with open(tmp_path / "dispatcher.log", "wb") as log:
            dispatcher = subprocess.Popen(mgrao_command("dispatcher", "--dask", cluster.address), env=env,
                                          stdout=log, stderr=subprocess.STDOUT)
        wait_until(lambda: _study_status(sqlite_db, study_id) == "finished", 240,
                   "the study, advanced by the dispatcher",
                   details=lambda: (tmp_path / "dispatcher.log").read_text(errors="replace")[-3000:] + cluster.logs())
        job = _job(sqlite_db, bad)
        assert (job.status, job.error) == (FAILED, _expected_error())
        with sqlite_db.session() as session:
            runners = set(session.scalars(select(Job.worker_id).where(Job.study_id == study_id)))
        assert all(runner.startswith("dispatcher:") for runner in runners)
    finally:
        if dispatcher is not None:
            stop(dispatcher)
        cluster.stop()
