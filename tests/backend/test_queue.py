"""The queue's data layer against a real SQLite file: claim, leases, stale re-queue, chunked results."""

from __future__ import annotations

import time
from datetime import timedelta

import numpy as np
import pytest
from sqlalchemy import event, func, select, update

from backend.execution.worker import Worker
from backend.settings import Settings
from backend.store import crud, queue
from backend.store.db import Database
from backend.store.models import Job, Run, utcnow
from mgrao_core import make_spec, run_chunk, run_experiment
from tests.support.waiting import join_all

SPEC = make_spec("single", seeds=4, episodes=12)


def add_job(db: Database, spec=SPEC) -> int:
    with db.write() as session:
        return crud.create_job(session, spec=spec).id


def age_heartbeat(db: Database, job_id: int, seconds: float) -> None:
    with db.write() as session:
        session.execute(update(Job).where(Job.id == job_id).values(heartbeat_at=utcnow() - timedelta(seconds=seconds)))


def store_all(db: Database, claim: queue.Claim, spec=SPEC) -> None:
    runs = run_chunk(spec, spec.seeds)
    assert queue.store_runs(db, claim=claim, rows=queue.run_rows(claim.job_id, runs), progress=1.0)


def test_claims_oldest_first_and_only_once(db: Database) -> None:
    ids = [add_job(db) for _ in range(3)]
    claims = [queue.claim(db, worker_id=f"w{i}", stale_after_s=60, max_attempts=3) for i in range(4)]
    assert [c.job_id for c in claims[:3]] == ids and claims[3] is None


def _writes(statement: str) -> bool:
    """A statement that takes a write lock: SQLite's BEGIN IMMEDIATE, an UPDATE, a row lock."""
    text = statement.upper()
    return "BEGIN IMMEDIATE" in text or text.lstrip().startswith("UPDATE") or "FOR UPDATE" in text


def test_an_idle_poll_takes_no_write_lock(db: Database) -> None:
    statements: list[str] = []

    def record(_conn, _cursor, statement, *_args) -> None:
        statements.append(statement)

    event.listen(db.engine, "before_cursor_execute", record)
    try:
        assert queue.claim(db, worker_id="w", stale_after_s=60, max_attempts=3) is None
        assert not any(_writes(s) for s in statements), statements
        add_job(db)
        statements.clear()
        assert queue.claim(db, worker_id="w", stale_after_s=60, max_attempts=3) is not None
        assert any(_writes(s) for s in statements)
    finally:
        event.remove(db.engine, "before_cursor_execute", record)


def test_stale_job_is_requeued_then_failed_after_max_attempts(db: Database) -> None:
    job_id = add_job(db)
    first = queue.claim(db, worker_id="a", stale_after_s=5, max_attempts=2)
    assert first is not None and first.attempt == 1
    assert queue.claim(db, worker_id="b", stale_after_s=5, max_attempts=2) is None  # heartbeat fresh
    age_heartbeat(db, job_id, 10)
    second = queue.claim(db, worker_id="b", stale_after_s=5, max_attempts=2)
    assert second is not None and second.job_id == job_id and second.attempt == 2
    assert second.lease != first.lease
    with db.session() as session:  # the reason stays on the job (the error does not: it has none)
        job = session.get(Job, job_id)
        assert job.requeue_reason == "worker a stopped sending heartbeats (none for over 5 s)"
        assert job.error is None
    # the first worker lost its lease: no heartbeat, no runs, no finish, no fail, no release
    rows = queue.run_rows(job_id, run_chunk(SPEC, SPEC.seeds[:1]))
    assert queue.heartbeat(db, claim=first) is False
    assert queue.store_runs(db, claim=first, rows=rows, progress=0.5) is False
    assert queue.finish(db, claim=first, expected_runs=12) is False
    assert queue.fail(db, claim=first, error="late") is False
    assert queue.release(db, claim=first) is False
    with db.session() as session:
        assert session.scalar(select(func.count()).select_from(Run)) == 0
        assert session.get(Job, job_id).lease == second.lease
    age_heartbeat(db, job_id, 10)
    assert queue.claim(db, worker_id="c", stale_after_s=5, max_attempts=2) is None
    with db.session() as session:
        job = session.get(Job, job_id)
        assert job.status == "failed" and "2 attempts" in job.error and "heartbeat" in job.error


def test_staleness_is_judged_by_the_database_clock(db: Database, monkeypatch: pytest.MonkeyPatch) -> None:
    # a worker whose clock runs an hour ahead must not re-queue a job that beat a second ago
    job_id = add_job(db)
    claim = queue.claim(db, worker_id="a", stale_after_s=60, max_attempts=3)
    assert queue.heartbeat(db, claim=claim) is True
    ahead = utcnow() + timedelta(hours=1)
    monkeypatch.setattr(queue, "utcnow", lambda: ahead)
    add_job(db)  # something to claim, so the claim does look for stale jobs
    other = queue.claim(db, worker_id="skewed", stale_after_s=60, max_attempts=3)
    assert other is not None and other.job_id != job_id
    with db.session() as session:
        job = session.get(Job, job_id)
        assert (job.status, job.lease) == ("running", claim.lease)
    assert queue.heartbeat(db, claim=claim) is True


def test_runs_are_stored_once_and_finish_needs_all_of_them(db: Database) -> None:
    job_id = add_job(db)
    claim = queue.claim(db, worker_id="a", stale_after_s=60, max_attempts=3)
    first = run_chunk(SPEC, SPEC.seeds[:2])
    rows = queue.run_rows(job_id, first)
    assert queue.store_runs(db, claim=claim, rows=rows, progress=0.5) is True
    assert queue.store_runs(db, claim=claim, rows=rows, progress=0.5) is True  # a second write is a no-op
    with pytest.raises(RuntimeError, match="6 of 12 runs"):
        queue.finish(db, claim=claim, expected_runs=12)
    with db.session() as session:
        assert session.get(Job, job_id).status == "running"  # the failed finish changed nothing
        assert queue.stored_seeds(session, job_id=job_id, algorithms=3) == set(SPEC.seeds[:2])
    rest = run_chunk(SPEC, SPEC.seeds[2:])
    assert queue.store_runs(db, claim=claim, rows=queue.run_rows(job_id, rest), progress=1.0) is True
    assert queue.finish(db, claim=claim, expected_runs=12) is True
    assert queue.finish(db, claim=claim, expected_runs=12) is False  # the lease is spent
    whole = {(r.algorithm, r.seed): r for r in run_experiment(SPEC).runs}
    with db.session() as session:
        runs = session.scalars(select(Run).where(Run.job_id == job_id)).all()
        assert len(runs) == 12
        for stored in runs:
            expected = whole[(stored.algorithm, stored.seed)]
            assert np.frombuffer(stored.utilities, dtype="<f8").tobytes() == expected.utilities.tobytes()


def test_release_returns_the_job_without_counting_the_attempt_and_keeps_its_runs(db: Database) -> None:
    job_id = add_job(db)
    claim = queue.claim(db, worker_id="a", stale_after_s=60, max_attempts=3)
    rows = queue.run_rows(job_id, run_chunk(SPEC, SPEC.seeds[:1]))
    assert queue.store_runs(db, claim=claim, rows=rows, progress=0.25)
    assert queue.release(db, claim=claim) is True
    with db.session() as session:
        job = session.get(Job, job_id)
        assert job.status == "queued" and job.attempts == 0 and job.progress == 0.25
        assert session.scalar(select(func.count()).select_from(Run)) == 3


def test_a_retried_job_computes_only_the_missing_seeds_and_equals_an_unsplit_run(db: Database, settings: Settings):
    spec = make_spec("multi", seeds=[3, 1, 4, 9], episodes=20)
    job_id = add_job(db, spec)
    claim = queue.claim(db, worker_id="crashed", stale_after_s=60, max_attempts=3)
    assert queue.store_runs(db, claim=claim, rows=queue.run_rows(job_id, run_chunk(spec, [1, 9])), progress=0.5)
    with db.session() as session:
        kept = {(r.algorithm, r.seed): r.id for r in session.scalars(select(Run)).all()}
    age_heartbeat(db, job_id, 3600)  # the worker died: its lease lapses
    worker = Worker(settings, worker_id="next")
    try:
        # a worker re-queues others' stale jobs once it has seen the database healthy for stale_after_s
        deadline = time.monotonic() + 30
        while not worker.run_once():
            assert time.monotonic() < deadline, "the stale job was never taken over"
            time.sleep(0.05)
    finally:
        worker.db.dispose()
    whole = {(r.algorithm, r.seed): r for r in run_experiment(spec).runs}
    with db.session() as session:
        job = session.get(Job, job_id)
        assert job.status == "succeeded" and job.attempts == 2
        runs = session.scalars(select(Run).where(Run.job_id == job_id)).all()
    assert len(runs) == 12
    for stored in runs:
        if (stored.algorithm, stored.seed) in kept:
            assert stored.id == kept[(stored.algorithm, stored.seed)]  # not recomputed or rewritten
        expected = whole[(stored.algorithm, stored.seed)]
        assert np.frombuffer(stored.utilities, dtype="<f8").tobytes() == expected.utilities.tobytes()
        assert np.frombuffer(stored.combined_weights, dtype="<f8").tobytes() == expected.combined_weights.tobytes()


def test_a_cancelled_job_keeps_its_completed_chunks(db: Database) -> None:
    job_id = add_job(db)
    claim = queue.claim(db, worker_id="a", stale_after_s=60, max_attempts=3)
    assert queue.store_runs(db, claim=claim, rows=queue.run_rows(job_id, run_chunk(SPEC, SPEC.seeds[:1])),
                            progress=0.25)
    with db.write() as session:
        crud.cancel_job(session, job_id=job_id)
    assert queue.store_runs(db, claim=claim, rows=queue.run_rows(job_id, run_chunk(SPEC, SPEC.seeds[1:2])),
                            progress=0.5) is False
    with db.session() as session:
        assert session.get(Job, job_id).status == "cancelled"
        assert queue.stored_seeds(session, job_id=job_id, algorithms=3) == {SPEC.seeds[0]}


def test_migrations_are_idempotent(db: Database) -> None:
    db.migrate()
    db.migrate()
    assert add_job(db) == 1


def test_cancel_racing_finish_has_exactly_one_winner(db: Database) -> None:
    # on PostgreSQL the two really interleave: each is one conditional update, so exactly one wins
    import threading

    from backend.errors import Conflict

    spec = make_spec("single", ["uniform"], seeds=1, episodes=3)
    rows_of = {}
    outcomes = []
    for _ in range(30):
        job_id = add_job(db, spec)
        claim = queue.claim(db, worker_id="w", stale_after_s=60, max_attempts=3)
        rows_of[job_id] = queue.run_rows(job_id, run_chunk(spec, spec.seeds))
        assert queue.store_runs(db, claim=claim, rows=rows_of[job_id], progress=1.0)
        result: dict[str, object] = {}
        barrier = threading.Barrier(2, timeout=60)

        def finish(claim=claim, result=result, barrier=barrier) -> None:
            barrier.wait()
            result["finished"] = queue.finish(db, claim=claim, expected_runs=1)

        def cancel(job_id=job_id, result=result, barrier=barrier) -> None:
            barrier.wait()
            try:
                with db.write() as session:
                    crud.cancel_job(session, job_id=job_id)
                result["cancelled"] = True
            except Conflict:
                result["cancelled"] = False

        threads = [threading.Thread(target=finish, daemon=True), threading.Thread(target=cancel, daemon=True)]
        for thread in threads:
            thread.start()
        join_all(threads, 60, f"the finish and the cancel of job {job_id}")
        with db.session() as session:
            status = session.get(Job, job_id).status
        assert result["finished"] != result["cancelled"], result
        assert status == ("succeeded" if result["finished"] else "cancelled")
        outcomes.append(status)
    assert set(outcomes) <= {"succeeded", "cancelled"}


def test_stale_requeue_never_takes_a_job_that_beat_meanwhile(db: Database) -> None:
    job_id = add_job(db)
    claim = queue.claim(db, worker_id="a", stale_after_s=5, max_attempts=3)
    age_heartbeat(db, job_id, 10)
    assert queue.heartbeat(db, claim=claim) is True  # the worker was only slow: it beats again
    with db.write() as session:
        assert queue.requeue_stale(session, stale_after_s=5, max_attempts=3) == []
    assert queue.heartbeat(db, claim=claim) is True


def test_after_an_outage_no_one_judges_heartbeats_stale_until_the_database_was_healthy_for_the_period(
        db: Database, settings: Settings) -> None:
    # during an outage every heartbeat stops, a live worker's too: right after it, a heartbeat older than
    # stale_after_s proves nothing, and re-queuing would cost the job an attempt while its worker lives
    job_id = add_job(db)
    holder = queue.claim(db, worker_id="holder", stale_after_s=settings.stale_after_s, max_attempts=3)
    age_heartbeat(db, job_id, 10 * settings.stale_after_s)  # no beat got through during the outage
    other = Worker(settings, worker_id="other")
    try:
        other.health.failure()  # it saw the outage too
        assert not other.run_once()  # not yet entitled to judge: the job stays with its worker
        assert queue.heartbeat(db, claim=holder) is True  # the live holder beats again
        time.sleep(settings.stale_after_s + 0.1)
        assert queue.heartbeat(db, claim=holder) is True
        assert not other.run_once()  # healthy for the period now, and the heartbeat is fresh
        with db.session() as session:
            job = session.get(Job, job_id)
            assert (job.status, job.lease, job.attempts) == ("running", holder.lease, 1)
        age_heartbeat(db, job_id, 10 * settings.stale_after_s)  # now the holder really is gone
        assert other.run_once() == 1  # taken over (and run to the end)
        with db.session() as session:
            assert session.get(Job, job_id).attempts == 2
    finally:
        other.db.dispose()
