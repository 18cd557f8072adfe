"""The job queue: the ``jobs`` table, claimed atomically, leased, heartbeaten, re-queued when stale.

Every state change of a claimed job is one conditional ``UPDATE`` on its id, its *lease* (a fresh
uuid per claim) and its status, so a worker that lost its job (cancelled, or re-queued as stale
and claimed by another worker) can neither heartbeat it, store runs for it nor finish it, on any
database and under any interleaving. Heartbeats are stamped, and staleness judged, by the
database's clock, never a worker's. A job's runs are stored chunk by chunk as they complete, each
at most once (unique ``(job, algorithm, seed)``; a second write is a no-op), so a retried job
computes only the runs still missing. An idle poll reads; it takes the write lock only when there
is a queued or a stale job to take.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from sqlalchemy import delete, exists, func, or_, select, update
from sqlalchemy.orm import Session

from backend.store import dialect, summaries
from backend.store.db import Database
from backend.store.models import FAILED, QUEUED, RUNNING, SIMULATION, SUCCEEDED, Job, Run, utcnow
from backend.store.run_storage import StoredRun, stored_runs
from mgrao_core import Run as SimulatedRun
from mgrao_core import summarise


@dataclass(frozen=True)
class Claim:
    """A job a worker holds: its id, the lease that proves it, the configuration and the attempt."""

    job_id: int
    lease: str
    config: dict[str, Any]
    attempt: int
    work: int | None = None
    """The job's atomic tasks (``jobs.work``), when the claim read it."""


def _stale(session: Session, stale_after_s: float) -> Any:
    return Job.heartbeat_at < dialect.db_now(session, minus_seconds=stale_after_s)


def _held(claim: Claim) -> tuple:
    return Job.id == claim.job_id, Job.lease == claim.lease, Job.status == RUNNING


def has_work(session: Session, *, stale_after_s: float, look_for_stale: bool = True) -> bool:
    """Whether a job is queued, or (if asked) a running job's heartbeat is stale: a read, no lock."""
    claimable = (Job.status == QUEUED) & (Job.kind == SIMULATION)
    if look_for_stale:
        claimable = or_(claimable, (Job.status == RUNNING) & _stale(session, stale_after_s))
    return bool(session.scalar(select(exists().where(claimable))))


def requeue_stale(session: Session, *, stale_after_s: float, max_attempts: int) -> list[int]:
    """Re-queue running jobs whose heartbeat is older than ``stale_after_s``; fail them after the last attempt.

    Call it inside a write transaction. Each change is conditional on the lease seen, so a job
    that beat or finished meanwhile is left alone. Returns the ids it changed.
    """
    return _requeue(session, max_attempts, lambda worker_id: f"worker {worker_id} stopped sending heartbeats (none "
                    f"for over {stale_after_s:g} s)", _stale(session, stale_after_s))


def requeue_of_worker(session: Session, *, worker_id: str, how: str, max_attempts: int) -> list[int]:
    """Re-queue the running jobs of a worker known to be gone (``how`` it ended); fail them after the last attempt.

    What its supervisor calls the moment it sees the worker exit, instead of waiting for its heartbeats to go stale.

    Call it inside a write transaction. Each change is conditional on the lease seen and the worker, so a job
    finished meanwhile (or already re-queued and claimed by another) is left alone. Returns the ids it changed.
    """
    return _requeue(session, max_attempts, lambda _: f"worker {worker_id} {how}", Job.worker_id == worker_id)


def _requeue(session: Session, max_attempts: int, reason_of: Callable[[str], str], condition: Any) -> list[int]:
    held = session.execute(
        select(Job.id, Job.lease, Job.attempts, Job.worker_id)
        .where(Job.status == RUNNING, Job.kind == SIMULATION, condition)
    ).all()
    changed = []
    for job_id, lease, attempts, worker_id in held:
        reason = reason_of(worker_id)
        if attempts >= max_attempts:
            values: dict[str, Any] = {
                "status": FAILED, "finished_at": utcnow(), "lease": None,
                "error": f"{reason}; gave up after {attempts} attempts",
            }
        else:
            values = {"status": QUEUED, "lease": None, "worker_id": None, "requeue_reason": reason}
        result = session.execute(
            update(Job).where(Job.id == job_id, Job.lease == lease, Job.status == RUNNING, condition).values(**values)
        )
        if result.rowcount == 1:
            changed.append(job_id)
    return changed


def claim(db: Database, *, worker_id: str, stale_after_s: float, max_attempts: int,
          requeue: bool = True) -> Claim | None:
    """Atomically take the oldest queued job, or None.

    With ``requeue``, stale jobs are re-queued first; a process passes it only once it has seen
    the database healthy for ``stale_after_s`` (see :class:`backend.store.retry.HealthClock`).
    """
    with db.session() as session:
        if not has_work(session, stale_after_s=stale_after_s, look_for_stale=requeue):
            return None
    with db.write() as session:
        if requeue:
            requeue_stale(session, stale_after_s=stale_after_s, max_attempts=max_attempts)
        claimable = (Job.status == QUEUED, Job.kind == SIMULATION)  # an external job is never a worker's
        oldest = dialect.skip_locked(
            session, select(Job.id).where(*claimable).order_by(Job.created_at, Job.id).limit(1)
        ).scalar_subquery()
        lease = str(uuid.uuid4())
        row = session.execute(
            update(Job).where(Job.id == oldest, *claimable)
            .values(status=RUNNING, lease=lease, worker_id=worker_id, attempts=Job.attempts + 1, compiling=None,
                    started_at=utcnow(), heartbeat_at=dialect.db_now(session), finished_at=None)
            .returning(Job.id, Job.config, Job.attempts)
        ).first()
        if row is None:
            return None
        return Claim(job_id=row.id, lease=lease, config=dict(row.config), attempt=row.attempts)


def claim_batch(db: Database, *, worker_id: str, stale_after_s: float, max_attempts: int, requeue: bool = True,
                small_work: int, limit: int) -> list[Claim]:
    """Atomically take the oldest queued job and, when it is small, the next small queued jobs; [] when none.

    A job is small when its ``work`` (atomic tasks) is at most ``small_work``; a job that is not (or
    whose work is unknown: stored before migration 0010) is claimed alone, as by :func:`claim`, so
    the queue's order holds and no worker hoards big jobs. At most ``limit`` jobs are taken, in the
    queue's order, in one conditional ``UPDATE`` that gives each the same fresh lease and counts an
    attempt for each: every later change of each job is conditional on its own id, that lease and
    its status, exactly as for a job claimed alone.
    """
    with db.session() as session:
        if not has_work(session, stale_after_s=stale_after_s, look_for_stale=requeue):
            return []
    with db.write() as session:
        if requeue:
            requeue_stale(session, stale_after_s=stale_after_s, max_attempts=max_attempts)
        queued = select(Job.id).where(Job.status == QUEUED, Job.kind == SIMULATION).order_by(Job.created_at, Job.id)
        first = session.execute(dialect.skip_locked(session, queued.add_columns(Job.work).limit(1))).first()
        if first is None:
            return []
        if first.work is None or first.work > small_work or limit <= 1:
            picked = [first.id]
        else:
            picked = list(session.scalars(dialect.skip_locked(
                session, queued.where(Job.work <= small_work).limit(limit))))
        lease = str(uuid.uuid4())
        rows = session.execute(
            update(Job).where(Job.id.in_(picked), Job.status == QUEUED)
            .values(status=RUNNING, lease=lease, worker_id=worker_id, attempts=Job.attempts + 1, compiling=None,
                    started_at=utcnow(), heartbeat_at=dialect.db_now(session), finished_at=None)
            .returning(Job.id, Job.config, Job.attempts, Job.work)
        ).all()
        order = {job_id: place for place, job_id in enumerate(picked)}
        return [Claim(job_id=row.id, lease=lease, config=dict(row.config), attempt=row.attempts, work=row.work)
                for row in sorted(rows, key=lambda row: order[row.id])]


UNCHANGED: Any = object()
"""A heartbeat's ``compiling`` that leaves the job's as it is."""


def heartbeat(db: Database, *, claim: Claim, progress: float | None = None, compiling: Any = UNCHANGED,
              compiled_s: float = 0.0) -> bool:
    """Record that the worker is alive (and its progress); False when the job is no longer ours.

    ``compiling`` is what the worker compiles for the job now (a :class:`mgrao_core.compiling.Compiling` as JSON,
    with ``since``), None once it is done, :data:`UNCHANGED` otherwise; ``compiled_s`` seconds of compiling to
    add to the job's ``compile_s``.
    """
    with db.write() as session:
        return _beat(session, claim, progress, compiling, compiled_s)


def _beat(session: Session, claim: Claim, progress: float | None, compiling: Any = UNCHANGED,
          compiled_s: float = 0.0) -> bool:
    values: dict[str, Any] = {"heartbeat_at": dialect.db_now(session)}
    if progress is not None:
        values["progress"] = progress
    if compiling is not UNCHANGED:
        values["compiling"] = compiling
    if compiled_s:
        values["compile_s"] = func.coalesce(Job.compile_s, 0.0) + compiled_s
    return session.execute(update(Job).where(*_held(claim)).values(**values)).rowcount == 1


def run_rows(job_id: int, runs: Iterable[SimulatedRun | StoredRun]) -> list[dict[str, Any]]:
    """The ``runs`` table rows of a job's runs: the core's runs, or their stored form sent back by a Dask worker.

    What a run keeps, and within which bounds, is :func:`backend.store.run_storage.stored_run`'s.
    """
    return [{"job_id": job_id} | row for row in stored_runs(runs)]


def store_runs(db: Database, *, claim: Claim, rows: Sequence[dict[str, Any]], progress: float) -> bool:
    """Store a chunk's runs and the job's progress in one transaction, if the job is still ours.

    A run already stored (same job, algorithm and seed) is left as it is. Returns False, storing
    nothing, when the job is no longer ours.
    """
    with db.write() as session:
        if not _beat(session, claim, progress):
            return False
        dialect.insert_ignoring_duplicates(session, Run, rows)
        return True


def stored_seeds(session: Session, *, job_id: int, algorithms: int) -> set[int]:
    """The seeds of which every algorithm's run is stored."""
    rows = session.execute(
        select(Run.seed).where(Run.job_id == job_id).group_by(Run.seed).having(func.count() == algorithms)
    )
    return {seed for (seed,) in rows}


def stored_seeds_of(session: Session, *, algorithms: dict[int, int]) -> dict[int, set[int]]:
    """:func:`stored_seeds` of many jobs in one query: ``algorithms`` maps each job to its algorithm count."""
    if not algorithms:
        return {}
    rows = session.execute(select(Run.job_id, Run.seed, func.count()).where(Run.job_id.in_(list(algorithms)))
                           .group_by(Run.job_id, Run.seed))
    out: dict[int, set[int]] = {}
    for job_id, seed, count in rows:
        if count == algorithms[job_id]:
            out.setdefault(job_id, set()).add(seed)
    return out


def record_stopped(db: Database, *, claim: Claim, stopped: dict[str, Any], progress: float) -> bool:
    """Store a job's stopping rule's verdicts so far (``jobs.stopped``) and its progress; False when not ours."""
    with db.write() as session:
        values = {"stopped": stopped, "progress": progress, "heartbeat_at": dialect.db_now(session)}
        return session.execute(update(Job).where(*_held(claim)).values(**values)).rowcount == 1


def finish(db: Database, *, claim: Claim, expected_runs: int, stopped: dict[str, Any] | None = None,
           seeds: Sequence[int] | None = None) -> bool:
    """Mark the job succeeded once every run is stored, with its summaries; False when the job is not ours.

    A job that ran until its rule answered stores why it stopped (``stopped``) and the ``seeds`` it ran as its
    configuration's (the rule, ``config["until"]``, says how many it might have run).

    Raises:
        RuntimeError: the job is ours but runs are missing (a bug: nothing is changed).
    """
    ran = {} if seeds is None else {"config": claim.config | {"seeds": list(seeds)}, "stopped": stopped}
    with db.write() as session:
        stored = session.scalar(select(func.count()).select_from(Run).where(Run.job_id == claim.job_id)) or 0
        result = session.execute(
            update(Job).where(*_held(claim))
            .values(status=SUCCEEDED, progress=1.0, finished_at=utcnow(), lease=None, error=None, **ran)
        )
        if result.rowcount != 1:
            return False
        if stored != expected_runs:  # leaving the transaction on the exception rolls the update back
            raise RuntimeError(f"job {claim.job_id} has {stored} of {expected_runs} runs stored")
        summaries.store(session, claim.job_id)  # the runs table's result columns, in the same transaction
        return True


@dataclass(frozen=True)
class Completed:
    """A job of a batch whose missing runs were all simulated: what :func:`finish_batch` stores and ends.

    ``finals`` holds every run's final utility (:func:`backend.store.summaries.finals_of_rows`) when
    ``rows`` are all of the job's runs, so that its summary is computed without reading them back;
    None when earlier attempts stored some of them (they are read back).
    """

    claim: Claim
    rows: list[dict[str, Any]]
    expected_runs: int
    finals: dict[str, dict[int, float]] | None = None


SUCCEEDED_NOW, NOT_OURS, INCOMPLETE = "succeeded", "not ours", "incomplete"


def finish_batch(db: Database, *, completed: Sequence[Completed]) -> dict[int, str]:
    """Store the runs of many completed jobs and mark them succeeded, with their summaries, in one transaction.

    Per job, exactly as :func:`store_runs` then :func:`finish`: its row is updated (and, on
    PostgreSQL, locked) on its id, lease and status first, so the runs of a job that is no longer
    ours (cancelled, or taken over) are not stored; a run already stored is left as it is; the job
    becomes ``succeeded`` only with every run stored. Returns each job's outcome:
    :data:`SUCCEEDED_NOW`, :data:`NOT_OURS` (nothing stored) or :data:`INCOMPLETE` (runs missing: a
    bug; its runs are stored, it stays running for the caller to fail).
    """
    outcome = {item.claim.job_id: NOT_OURS for item in completed}
    if not completed:
        return outcome
    with db.write() as session:
        now = dialect.db_now(session)
        held: set[int] = set()
        by_lease: dict[str, list[int]] = {}
        for item in completed:
            by_lease.setdefault(item.claim.lease, []).append(item.claim.job_id)
        for lease, ids in by_lease.items():
            held.update(session.scalars(
                update(Job).where(Job.id.in_(ids), Job.lease == lease, Job.status == RUNNING)
                .values(heartbeat_at=now, progress=1.0).returning(Job.id)
                .execution_options(synchronize_session=False)))
        ours = [item for item in completed if item.claim.job_id in held]
        dialect.insert_ignoring_duplicates(session, Run, [row for item in ours for row in item.rows])
        counts = dict(session.execute(select(Run.job_id, func.count()).where(Run.job_id.in_(held))
                                      .group_by(Run.job_id)).all()) if held else {}
        done = [item for item in ours if counts.get(item.claim.job_id, 0) == item.expected_runs]
        for item in ours:
            outcome[item.claim.job_id] = INCOMPLETE
        done_by_lease: dict[str, list[int]] = {}
        for item in done:  # still held: this transaction updated (and locked) each row above
            done_by_lease.setdefault(item.claim.lease, []).append(item.claim.job_id)
            outcome[item.claim.job_id] = SUCCEEDED_NOW
        finished_at = utcnow()
        for lease, ids in done_by_lease.items():  # one statement per lease (a batch has one), each row on its own
            session.execute(update(Job).where(Job.id.in_(ids), Job.lease == lease, Job.status == RUNNING)
                            .values(status=SUCCEEDED, progress=1.0, finished_at=finished_at, lease=None, error=None)
                            .execution_options(synchronize_session=False))
        whole = [item for item in done if item.finals is not None]  # its rows are every run it has
        summaries.write(session, {item.claim.job_id: summarise(summaries.in_seed_order(item.finals,
                                                                                    item.claim.config["seeds"]))
                                  for item in whole},
                        {item.claim.job_id: summaries.task_counts_of_rows(item.rows) for item in whole})
        for item in done:
            if item.finals is None:
                summaries.store(session, item.claim.job_id)
    return outcome


def fail(db: Database, *, claim: Claim, error: str, discard_runs: bool = False) -> bool:
    """Mark the job failed with ``error`` (dropping its stored runs if asked); False when it is not ours."""
    with db.write() as session:
        result = session.execute(
            update(Job).where(*_held(claim)).values(status=FAILED, error=error[:2000], finished_at=utcnow(), lease=None)
        )
        if result.rowcount == 1 and discard_runs:
            session.execute(delete(Run).where(Run.job_id == claim.job_id))
        return result.rowcount == 1


def release_many(db: Database, *, claims: Sequence[Claim]) -> int:
    """Give jobs back to the queue in one transaction (as :func:`release` each); how many were still ours."""
    released = 0
    with db.write() as session:
        for claim in claims:
            released += session.execute(
                update(Job).where(*_held(claim))
                .values(status=QUEUED, lease=None, worker_id=None, attempts=Job.attempts - 1)
            ).rowcount
    return released


def release(db: Database, *, claim: Claim) -> bool:
    """Give a job back to the queue (worker shutting down); the attempt does not count; stored runs stay."""
    with db.write() as session:
        result = session.execute(
            update(Job).where(*_held(claim))
            .values(status=QUEUED, lease=None, worker_id=None, attempts=Job.attempts - 1)
        )
        return result.rowcount == 1
