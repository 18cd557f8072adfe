"""The queue's data layer against a real SQLite file: claim, leases, stale re-queue, results."""

from __future__ import annotations

from datetime import timedelta

import numpy as np
from sqlalchemy import func, select, update

from backend import crud, queue
from backend.db import Database
from backend.models import Job, Run, utcnow
from mgrao_core import make_spec, run_experiment

SPEC = make_spec("single", seeds=2, episodes=12)


def add_job(db: Database) -> int:
    with db.write() as session:
        return crud.create_job(session, spec=SPEC).id


def age_heartbeat(db: Database, job_id: int, seconds: float) -> None:
    with db.write() as session:
        session.execute(update(Job).where(Job.id == job_id).values(heartbeat_at=utcnow() - timedelta(seconds=seconds)))


def test_claims_oldest_first_and_only_once(db: Database) -> None:
    ids = [add_job(db) for _ in range(3)]
    claims = [queue.claim(db, worker_id=f"w{i}", stale_after_s=60, max_attempts=3) for i in range(4)]
    assert [c.job_id for c in claims[:3]] == ids and claims[3] is None


def test_stale_job_is_requeued_then_failed_after_max_attempts(db: Database) -> None:
    job_id = add_job(db)
    first = queue.claim(db, worker_id="a", stale_after_s=5, max_attempts=2)
    assert first is not None and first.attempt == 1
    assert queue.claim(db, worker_id="b", stale_after_s=5, max_attempts=2) is None  # heartbeat fresh
    age_heartbeat(db, job_id, 10)
    second = queue.claim(db, worker_id="b", stale_after_s=5, max_attempts=2)
    assert second is not None and second.job_id == job_id and second.attempt == 2
    assert second.lease != first.lease
    # the first worker lost its lease: no heartbeat, no results
    assert queue.heartbeat(db, claim=first) is False
    result = run_experiment(SPEC)
    assert queue.finish(db, claim=first, result=result) is False
    age_heartbeat(db, job_id, 10)
    assert queue.claim(db, worker_id="c", stale_after_s=5, max_attempts=2) is None
    with db.session() as session:
        job = session.get(Job, job_id)
        assert job.status == "failed" and "2 attempts" in job.error and "heartbeat" in job.error


def test_finish_stores_each_run_once_and_bit_identical(db: Database) -> None:
    job_id = add_job(db)
    claim = queue.claim(db, worker_id="a", stale_after_s=60, max_attempts=3)
    result = run_experiment(SPEC)
    assert queue.heartbeat(db, claim=claim, progress=0.5) is True
    assert queue.finish(db, claim=claim, result=result) is True
    assert queue.finish(db, claim=claim, result=result) is False  # no second copy
    with db.session() as session:
        runs = session.scalars(select(Run).where(Run.job_id == job_id).order_by(Run.id)).all()
        assert len(runs) == len(result.runs)
        for stored, run in zip(runs, result.runs, strict=True):
            assert (stored.algorithm, stored.seed) == (run.algorithm, run.seed)
            assert np.array_equal(np.frombuffer(stored.utilities, dtype="<f8"), run.utilities)
        assert session.scalar(select(func.count()).select_from(Run)) == 6


def test_release_returns_the_job_without_counting_the_attempt(db: Database) -> None:
    job_id = add_job(db)
    claim = queue.claim(db, worker_id="a", stale_after_s=60, max_attempts=3)
    assert queue.release(db, claim=claim) is True
    with db.session() as session:
        job = session.get(Job, job_id)
        assert job.status == "queued" and job.attempts == 0


def test_migrations_are_idempotent(db: Database) -> None:
    db.migrate()
    db.migrate()
    assert add_job(db) == 1
