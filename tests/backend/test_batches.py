"""Small jobs in batches (issue 23) across killed processes: each job ends exactly once, none lost, none stored twice.

Real ``mgrao serve`` and ``mgrao worker`` processes on real SQLite files and PostgreSQL databases,
killed with SIGKILL; every wait has a deadline. Each small job here simulates a few tens of
milliseconds, so a batch of up to 64 lasts long enough to be killed in the middle.
"""

from __future__ import annotations

import re
import signal
from collections import Counter

import pytest
from backend_helpers import JSON, Service, drain
from fastapi.testclient import TestClient
from sqlalchemy import func, select, text

from backend.execution.worker import Worker
from backend.store.db import Database
from backend.store.models import Job, Run, Trial

SMALL = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 1, "episodes": 1500}
"""A small job (work 150,000 atomic tasks, under MGRAO_SMALL_JOB_WORK's 200,000): claimed in batches."""


BATCH_LOG = re.compile(r"runs a batch of \d+ jobs")


def _jobs(db_url: str, **where: object) -> list[Job]:
    db = Database(db_url)
    try:
        with db.session() as session:
            return list(session.scalars(select(Job).filter_by(**where).order_by(Job.id)))
    finally:
        db.dispose()


def _runs(db_url: str) -> tuple[dict[int, int], int, int]:
    """Runs per job, distinct (job, algorithm, seed) and all stored runs."""
    db = Database(db_url)
    try:
        with db.session() as session:
            per_job = dict(session.execute(select(Run.job_id, func.count()).group_by(Run.job_id)).all())
            distinct = session.scalar(select(func.count()).select_from(
                select(Run.job_id, Run.algorithm, Run.seed).distinct().subquery()))
            total = session.scalar(select(func.count()).select_from(Run))
    finally:
        db.dispose()
    return per_job, distinct, total


def assert_each_ran_once(db_url: str, ids: list[int], in_flight: list[int]) -> None:
    """Every job of ``ids`` succeeded, those killed ``in_flight`` at attempt 2; none lost, no run stored twice."""
    jobs = {job.id: job for job in _jobs(db_url)}
    assert Counter(job.status for job in jobs.values()) == {"succeeded": len(ids)}
    assert all(jobs[job_id].attempts == 2 for job_id in in_flight)  # re-run once: the killed batch
    per_job, distinct, total = _runs(db_url)
    assert per_job == dict.fromkeys(ids, 2)  # none lost (each job: 1 seed x 2 algorithms)
    assert distinct == total == 2 * len(ids)  # no run stored twice


def _in_flight_after_kill(db_url: str) -> list[int]:
    """The jobs still running once the killed worker's last transaction has ended, committed or rolled back.

    On PostgreSQL the server finishes a transaction whose COMMIT the worker sent just before it died: a plain
    read right after the kill could count as in flight a batch about to succeed at its first attempt (the race
    that once failed this test). Reading the running rows ``FOR UPDATE`` waits (60 s at most) for the row
    locks that transaction holds, then sees what it left. On SQLite a transaction is committed or not when its
    process dies.
    """
    db = Database(db_url)
    try:
        with db.write() as session:
            if session.get_bind().dialect.name == "postgresql":
                session.execute(text("SET LOCAL lock_timeout = '60s'"))
            return list(session.scalars(select(Job.id).where(Job.status == "running").order_by(Job.id)
                                        .with_for_update()))
    finally:
        db.dispose()


def _running(service: Service) -> int:
    return service.get("/api/jobs", params={"status": "running", "limit": 1}).json()["count"]


def _succeeded(service: Service) -> int:
    return service.get("/api/jobs", params={"status": "succeeded", "limit": 1}).json()["count"]


@pytest.mark.slow
def test_a_worker_killed_in_the_middle_of_a_batch_leaves_every_job_run_once(service: Service, db_url: str) -> None:
    service.start_server(workers=0)
    answer = service.post("/api/jobs/batch", json={"jobs": [SMALL | {"name": f"b{i}"} for i in range(150)]})
    assert answer.status_code == 202, answer.text
    ids = [job["id"] for job in answer.json()["data"]]
    victim = service.start_worker()
    # a batch claimed and being simulated: many jobs running at once, none of them stored yet
    # (the log line too: it follows the claim's commit by the time to parse the batch's configurations)
    service.wait_for(lambda: _running(service) >= 10 and BATCH_LOG.search(service.logs()), timeout=120,
                     what="a batch claimed and its run begun (logged)", step=0.02)
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    in_flight = _in_flight_after_kill(db_url)
    assert len(in_flight) >= 10, "the worker was not killed in the middle of a batch"

    service.start_worker()  # re-queues the dead worker's jobs once their heartbeats are stale (2 s)
    service.wait_for(lambda: _succeeded(service) == len(ids), timeout=240, what="every job succeeded")
    assert_each_ran_once(db_url, ids, in_flight)


@pytest.mark.slow
def test_a_grid_study_of_small_trials_runs_every_cell_once_across_a_killed_service(service: Service,
                                                                                   db_url: str) -> None:
    service.env["MGRAO_STUDY_POLL_S"] = "0.3"
    service.start_server(workers=1)
    study = {"name": "batches", "method": "grid", "base": SMALL,
             "space": {"learning_rate": {"low": 0.01, "high": 0.5, "steps": 16, "log": True},
                       "trace_decay": {"low": 0.1, "high": 0.99, "steps": 8}},
             "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform"},
             "max_trials": 128, "max_in_flight": 30}  # about a second of trials left when the kill lands
    study_id = service.post("/api/studies", json=study).json()["study"]["id"]
    status = lambda: service.get(f"/api/studies/{study_id}", params={"trials": "false"}).json()["study"]  # noqa: E731
    service.wait_for(lambda: status()["trials"].get("succeeded", 0) >= 5, timeout=120, what="five trials",
                     step=0.02)
    service.kill_server()  # its worker follows it (its lifeline), in the middle of a batch or between two
    assert status_after_kill(db_url, study_id) < 128

    service.start_server(workers=2)
    service.wait_for(lambda: status()["status"] == "finished", timeout=240, what="the study finished")
    assert status()["trials"] == {"succeeded": 128}
    db = Database(db_url)
    try:
        with db.session() as session:
            numbers = sorted(session.scalars(select(Trial.number).where(Trial.study_id == study_id)))
            per_trial = Counter(session.scalars(select(Job.trial_id).where(Job.study_id == study_id)))
    finally:
        db.dispose()
    assert numbers == list(range(128))  # every cell made once
    assert len(per_trial) == 128 and set(per_trial.values()) == {1}  # one job each
    per_job, distinct, total = _runs(db_url)
    assert set(per_job.values()) == {2} and len(per_job) == 128
    assert distinct == total == 256  # no run stored twice


def status_after_kill(db_url: str, study_id: int) -> int:
    """Trials that succeeded when the service was killed."""
    db = Database(db_url)
    try:
        with db.session() as session:
            return session.scalar(select(func.count()).select_from(Trial).where(
                Trial.study_id == study_id, Trial.status == "succeeded")) or 0
    finally:
        db.dispose()


@pytest.mark.slow
def test_cancelling_a_study_of_small_trials_stops_its_batches(service: Service, db_url: str) -> None:
    service.env["MGRAO_STUDY_POLL_S"] = "0.3"
    service.start_server(workers=1)
    study = {"name": "cancelled", "method": "random", "base": SMALL,
             "space": {"learning_rate": {"low": 0.01, "high": 0.5, "log": True}},
             "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform"},
             "max_trials": 2000, "max_in_flight": 100}
    study_id = service.post("/api/studies", json=study).json()["study"]["id"]
    service.wait_for(lambda: _succeeded(service) >= 30, timeout=120, what="thirty trials", step=0.02)
    answer = service.post(f"/api/studies/{study_id}/cancel", headers=JSON)
    assert answer.status_code == 200, answer.text
    # the stop: no job of the study runs any longer, and none succeeds after the cancel
    service.wait_for(lambda: _running(service) == 0, timeout=30, what="no job running", step=0.02)
    stored = _succeeded(service)
    service.wait_for(lambda: "runs a batch" in service.logs(), timeout=5, what="batches in the log")
    jobs = _jobs(db_url, study_id=study_id)
    assert Counter(job.status for job in jobs) == {"succeeded": stored, "cancelled": len(jobs) - stored}
    per_job, distinct, total = _runs(db_url)
    assert set(per_job) == {job.id for job in jobs if job.status == "succeeded"}  # nothing of a cancelled job
    assert distinct == total
    assert service.get(f"/api/studies/{study_id}").json()["study"]["status"] == "cancelled"
    assert _succeeded(service) == stored  # still: nothing ran on


def test_a_batch_submit_queues_every_job_or_none(client: TestClient, worker: Worker, db_url: str) -> None:
    answer = client.post("/api/jobs/batch", headers=JSON, json={"jobs": [SMALL | {"name": f"j{i}"} for i in range(5)]})
    assert answer.status_code == 202, answer.text
    assert [job["name"] for job in answer.json()["data"]] == [f"j{i}" for i in range(5)]
    bad = client.post("/api/jobs/batch", headers=JSON,
                      json={"jobs": [SMALL, SMALL | {"params": {"learning_rate": -1}}]})
    assert bad.status_code == 422 and bad.json()["detail"][0]["loc"][:3] == ["body", "jobs", 1], bad.text
    mistyped = client.post("/api/jobs/batch", headers=JSON, json={"jobs": [SMALL, SMALL | {"episodes": {}}]})
    assert mistyped.status_code == 422 and mistyped.json()["detail"] == [  # the field, not only its job
        {"loc": ["body", "jobs", 1, "episodes"], "field": "jobs[1].episodes",
         "msg": "jobs[1].episodes: must be a whole number (got dict)", "type": "int_type"}], mistyped.text
    assert drain(worker) == 5  # one batch: nothing of the refused request was queued
    per_job, distinct, total = _runs(db_url)
    assert per_job == dict.fromkeys((job["id"] for job in answer.json()["data"]), 2) and distinct == total == 10
