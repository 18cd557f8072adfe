"""The job queue: the ``jobs`` table, claimed atomically, leased, heartbeaten, re-queued when stale.

Every state change of a running job is conditional on its *lease* (a fresh uuid per claim), so
a worker that lost its job (cancelled, or re-queued as stale and claimed by another worker)
can neither heartbeat it nor write its results.
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass
from datetime import timedelta
from typing import Any

import numpy as np
from sqlalchemy import delete, select, update
from sqlalchemy.orm import Session

from backend import dialect
from backend.db import Database
from backend.models import FAILED, QUEUED, RUNNING, SUCCEEDED, Job, Run, utcnow
from mgrao_core import ExperimentResult


@dataclass(frozen=True)
class Claim:
    """A job a worker holds: its id, the lease that proves it, the configuration and the attempt."""

    job_id: int
    lease: str
    config: dict[str, Any]
    attempt: int


def requeue_stale(session: Session, *, stale_after_s: float, max_attempts: int) -> list[int]:
    """Re-queue running jobs whose heartbeat is older than ``stale_after_s``; fail them after the last attempt.

    Call it inside a write transaction. Returns the ids it touched.
    """
    cutoff = utcnow() - timedelta(seconds=stale_after_s)
    stale = session.execute(
        select(Job.id, Job.attempts, Job.worker_id).where(Job.status == RUNNING, Job.heartbeat_at < cutoff)
    ).all()
    for job_id, attempts, worker_id in stale:
        reason = f"worker {worker_id} stopped sending heartbeats (none for over {stale_after_s:g} s)"
        if attempts >= max_attempts:
            values: dict[str, Any] = {
                "status": FAILED, "finished_at": utcnow(), "lease": None,
                "error": f"{reason}; gave up after {attempts} attempts",
            }
        else:
            values = {"status": QUEUED, "lease": None, "worker_id": None, "progress": 0.0,
                      "error": f"re-queued: {reason}"}
        session.execute(update(Job).where(Job.id == job_id, Job.status == RUNNING).values(**values))
    return [row[0] for row in stale]


def claim(db: Database, *, worker_id: str, stale_after_s: float, max_attempts: int) -> Claim | None:
    """Atomically take the oldest queued job (re-queuing stale ones first), or None."""
    with db.sessions() as session, session.begin():
        statement = dialect.lock_for_claim(
            session,
            select(Job).where(Job.status == QUEUED).order_by(Job.created_at, Job.id).limit(1),
        )
        requeue_stale(session, stale_after_s=stale_after_s, max_attempts=max_attempts)
        job = session.scalars(statement).first()
        if job is None:
            return None
        now = utcnow()
        job.status, job.lease, job.worker_id = RUNNING, str(uuid.uuid4()), worker_id
        job.attempts += 1
        job.progress, job.started_at, job.heartbeat_at, job.finished_at = 0.0, now, now, None
        return Claim(job_id=job.id, lease=job.lease, config=dict(job.config), attempt=job.attempts)


def heartbeat(db: Database, *, claim: Claim, progress: float | None = None) -> bool:
    """Record that the worker is alive (and its progress); False when the job is no longer ours."""
    values: dict[str, Any] = {"heartbeat_at": utcnow()}
    if progress is not None:
        values["progress"] = progress
    with db.write() as session:
        result = session.execute(
            update(Job).where(Job.id == claim.job_id, Job.lease == claim.lease, Job.status == RUNNING)
            .values(**values)
        )
        return result.rowcount == 1


def _owned(session: Session, claim: Claim) -> bool:
    return session.scalar(
        select(Job.id).where(Job.id == claim.job_id, Job.lease == claim.lease, Job.status == RUNNING)
    ) is not None


def _blob(array: np.ndarray) -> bytes:
    return np.ascontiguousarray(array, dtype="<f8").tobytes()


def finish(db: Database, *, claim: Claim, result: ExperimentResult) -> bool:
    """Store every run and mark the job succeeded, in one transaction; False when the job is not ours."""
    with db.write() as session:
        if not _owned(session, claim):
            return False
        session.execute(delete(Run).where(Run.job_id == claim.job_id))
        session.add_all(
            Run(
                job_id=claim.job_id, algorithm=run.algorithm, seed=run.seed, episodes=len(run.utilities),
                utilities=_blob(run.utilities), combined_weights=_blob(run.combined_weights),
                group_weights=_blob(run.group_weights), group_shape=list(run.group_weights.shape),
            )
            for run in result.runs
        )
        session.execute(
            update(Job).where(Job.id == claim.job_id)
            .values(status=SUCCEEDED, progress=1.0, finished_at=utcnow(), lease=None, error=None)
        )
        return True


def fail(db: Database, *, claim: Claim, error: str) -> bool:
    """Mark the job failed with ``error``; False when the job is not ours."""
    with db.write() as session:
        result = session.execute(
            update(Job).where(Job.id == claim.job_id, Job.lease == claim.lease, Job.status == RUNNING)
            .values(status=FAILED, error=error[:2000], finished_at=utcnow(), lease=None)
        )
        return result.rowcount == 1


def release(db: Database, *, claim: Claim) -> bool:
    """Give a job back to the queue (worker shutting down); the attempt does not count."""
    with db.write() as session:
        result = session.execute(
            update(Job).where(Job.id == claim.job_id, Job.lease == claim.lease, Job.status == RUNNING)
            .values(status=QUEUED, lease=None, worker_id=None, progress=0.0, attempts=Job.attempts - 1)
        )
        return result.rowcount == 1
