"""A local worker process: warm up the engine, then claim and run jobs until told to stop.

A job runs chunk by chunk (every algorithm over a block of seeds, sized by the job memory
budget); each chunk's runs are stored as soon as it completes, so a retried job computes only
what is missing. While a job runs, a heartbeat thread records that the worker is alive and the
job's progress, and notices a cancel (the job's lease is gone), which makes the run's
``should_stop`` True.

Small jobs (``MGRAO_SMALL_JOB_WORK``) are claimed in batches of up to ``MGRAO_BATCH_JOBS``: one
transaction claims them, each runs as its own job (its own configuration, :func:`mgrao_core.run_chunk`
on one numba thread), and one transaction stores every run of the batch and marks each job
succeeded, each conditional on its own lease; then each study of the batch advances once (handed to
the API's study driver under ``mgrao serve``: :mod:`backend.wakeup`). An idle worker under ``mgrao serve``
waits on its wake-up socket, woken when jobs are queued, and polls every ``MGRAO_POLL_S`` all the same.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, TypeVar

from backend import wakeup
from backend.execution.handback import local_worker_id
from backend.execution.heartbeats import Heartbeats
from backend.execution.lifecycle import Ended, Lifecycle, Plan
from backend.execution.lifeline import StopEvent, stop_on_signals
from backend.execution.presence import Presence, refresh_interval
from backend.execution.small_jobs import BATCH_BYTES, one_numba_thread, run_small_job, small_spec
from backend.settings import Settings
from backend.store import queue
from backend.store.db import Database
from backend.store.retry import Backoff, HealthClock, OutageLog, Stopping
from backend.store.run_storage import stored_bytes

if TYPE_CHECKING:
    from mgrao_core import ExperimentSpec
    from mgrao_core.compiling import Compiling

log = logging.getLogger("mgrao.worker")
T = TypeVar("T")

class Worker:
    """Claims queued jobs one at a time and runs them chunk by chunk with :func:`mgrao_core.run_chunk`.

    No database error stops a worker: every call is retried with a capped backoff until it goes
    through or the worker is told to stop; a job whose lease lapses meanwhile is taken over by
    another worker, which resumes it from the chunks already stored. Whenever a job ends, each of
    ``on_ended`` is told (see :mod:`backend.execution.lifecycle`).
    """

    def __init__(self, settings: Settings, *, worker_id: str | None = None, on_ended: Sequence[Ended] = ()) -> None:
        self.settings = settings
        self.db = Database(settings.database_url, settings.db_busy_timeout_s)
        self.worker_id = worker_id or local_worker_id(os.getpid())
        self.shutdown = StopEvent()  # set by a signal handler
        self.wake: wakeup.Listener | None = None
        self.health = HealthClock()
        self.lifecycle = Lifecycle(self.db, settings, owner_id=self.worker_id, shutdown=self.shutdown,
                                   health=self.health, on_ended=on_ended)

    def stop(self, *_: object) -> None:
        """Ask the worker to stop (the running job is handed back to the queue)."""
        self.shutdown.set()
        if self.wake is not None:
            self.wake.poke()

    def install_signal_handlers(self) -> None:
        """Stop cleanly on SIGTERM and SIGINT."""
        stop_on_signals(self.stop)

    def warm_up(self) -> None:
        """Load (or compile) the numba engine of the paper's configurations before claiming jobs.

        A job with other learners, or several resources, loads (or compiles, once) its own
        combination when it runs (:mod:`mgrao_core.engine.kernel`).
        """
        from mgrao_core import make_spec, run_experiment

        run_experiment(make_spec("single", seeds=1, episodes=2))

    def compile_notices(self, beats: Heartbeats, job_id: int) -> Callable[[Compiling], None]:
        """What a run tells of a compile for the job: into its log, and through ``beats`` into the job."""
        def notice(compiling: Compiling) -> None:
            log.info("job %s: %s", job_id, compiling.message)
            beats.compiling(job_id, compiling)

        return notice

    def persist(self, call: Callable[[], T], what: str) -> T:
        """``call()``, retried on database errors until it succeeds (see :mod:`backend.store.retry`)."""
        return self.lifecycle.persist(call, what)

    def run_once(self) -> int:
        """Claim and run one job, or a batch of small ones; how many (0: the queue was empty)."""
        try:
            claims = self.lifecycle.claim_batch(requeue=self.lifecycle.may_requeue())
        except Exception:
            self.health.failure()
            raise
        self.health.success()
        if not claims:
            return 0
        try:
            specs = {claim.job_id: small_spec(self.settings, claim) for claim in claims}
            for claim in claims:  # a job big in work or in memory runs chunk by chunk, within its memory budget
                if specs[claim.job_id] is None:
                    self.execute(claim)
            batch = [claim for claim in claims if specs[claim.job_id] is not None]
            if batch:
                self.execute_batch(batch, specs)
        except Stopping as error:
            log.warning("jobs %s left to their leases: %s", [c.job_id for c in claims], error)
        return len(claims)

    def execute_batch(self, claims: Sequence[queue.Claim],
                      specs: Mapping[int, ExperimentSpec | None] | None = None) -> None:
        """Run a batch of small claimed jobs, each as its own job, then store and end them all at once.

        Each job ends exactly as alone: succeeded (every run stored in the batch's transaction,
        conditional on its lease), failed with its own error, not ours (cancelled or taken over
        meanwhile: nothing stored), or handed back when the worker stops. A worker killed at any
        point leaves every job of the batch to its lease (re-queued when stale); none is half-stored.
        """
        from mgrao_core import Cancelled, MgraoError

        lifecycle = self.lifecycle
        log.info("worker %s runs a batch of %s jobs (%s to %s)", self.worker_id, len(claims), claims[0].job_id,
                 claims[-1].job_id)
        beats = Heartbeats(self.db, heartbeat_s=self.settings.heartbeat_s, progress_s=self.settings.progress_s,
                           name=f"heartbeat-batch-{claims[0].job_id}", health=self.health)
        for claim in claims:
            beats.add(claim)
        beats.start()
        failed: list[tuple[queue.Claim, BaseException]] = []
        completed: list[queue.Completed] = []
        left: list[queue.Claim] = []
        held = 0

        def store() -> None:
            nonlocal held
            failed.extend(lifecycle.finish_batch(completed))
            completed.clear()
            held = 0

        try:
            plans = lifecycle.plan_batch(claims, specs)
            with one_numba_thread():
                for claim in claims:
                    plan = plans[claim.job_id]
                    if self.shutdown.is_set():
                        left.append(claim)
                        continue
                    if beats.lost(claim.job_id):
                        continue
                    if isinstance(plan, BaseException):
                        failed.append((claim, plan))
                        continue
                    try:
                        runs = run_small_job(plan.spec, plan.chunks, should_stop=lambda job_id=claim.job_id:
                                             beats.lost(job_id) or self.shutdown.is_set(),
                                             on_compile=self.compile_notices(beats, claim.job_id))
                    except Cancelled:
                        if not beats.lost(claim.job_id):
                            left.append(claim)
                        continue
                    except Exception as error:
                        if not isinstance(error, MgraoError):  # a bug: its traceback goes to the log
                            log.exception("job %s failed", claim.job_id)
                        failed.append((claim, error))
                        continue
                    completed.append(plan.completed(claim, runs))
                    held += sum(stored_bytes(row) for row in completed[-1].rows)
                    if held > BATCH_BYTES:
                        store()
            store()
            for claim, error in failed:
                lifecycle.fail(claim, error)
            if left:
                lifecycle.release_many(left)
        finally:
            beats.close()
        lifecycle.ended(*(claim.job_id for claim in claims))

    def execute(self, claim: queue.Claim) -> None:
        """Run a claimed job to its end: succeeded, failed, cancelled or handed back."""
        from mgrao_core import Cancelled, MgraoError, run_chunk

        log.info("worker %s runs job %s (attempt %s)", self.worker_id, claim.job_id, claim.attempt)
        lifecycle = self.lifecycle
        beats = Heartbeats(self.db, heartbeat_s=self.settings.heartbeat_s, progress_s=self.settings.progress_s,
                           name=f"heartbeat-{claim.job_id}", health=self.health)
        beats.add(claim)
        beats.start()

        def should_stop() -> bool:  # the job was taken from us (cancel) or the worker is stopping
            return beats.lost(claim.job_id) or self.shutdown.is_set()

        try:
            plan: Plan | None = lifecycle.plan(claim)
            seeds, finished = len(plan.spec.seeds), plan.done_seeds
            while True:  # once; with a stopping rule, once per block until the rule answers
                for chunk in plan.chunks:
                    def progress(fraction: float, chunk: tuple[int, ...] = chunk, finished: int = finished) -> None:
                        beats.set_progress(claim.job_id, (finished + fraction * len(chunk)) / seeds)

                    runs = run_chunk(plan.spec, chunk, on_progress=progress, should_stop=should_stop,
                                     on_compile=self.compile_notices(beats, claim.job_id))
                    rows = queue.run_rows(claim.job_id, runs)
                    del runs
                    finished += len(chunk)
                    stored = lifecycle.store(claim, rows, finished / seeds, plan)
                    del rows
                    if not stored:
                        log.info("job %s was cancelled or taken over; stopped", claim.job_id)
                        return
                if plan.stopped:
                    break
                if should_stop():
                    raise Cancelled()  # between two blocks: handed back, or left to whoever cancelled it
                plan = lifecycle.judge_block(claim, plan)
                if plan is None:
                    log.info("job %s was cancelled or taken over; stopped", claim.job_id)
                    return
            if not lifecycle.finish(claim, plan):
                log.info("job %s was cancelled or taken over before it finished", claim.job_id)
        except Cancelled:
            if not beats.lost(claim.job_id):
                lifecycle.release(claim)
        except Stopping:
            raise
        except Exception as error:
            if not isinstance(error, MgraoError):  # a bug: its traceback goes to the log
                log.exception("job %s failed", claim.job_id)
            lifecycle.fail(claim, error)
        finally:
            beats.close()
        lifecycle.ended(claim.job_id)

    def serve_forever(self, *, warm_up: bool = True) -> None:
        """Migrate, warm up, then run jobs until :meth:`stop`; database errors are waited out.

        The ``workers`` table says meanwhile that this process is alive, warming up, then ready.
        """
        try:
            self.persist(lambda: self.db.migrate(create_missing=False), "migrating the database")
        except Stopping:
            return
        presence = Presence(self.db, self.worker_id, kind="local", interval_s=refresh_interval(self.settings))
        presence.start()
        try:
            if warm_up:
                self.warm_up()
            self.wake = wakeup.Listener.open(f"{wakeup.WORKER_PREFIX}{os.getpid()}")
            presence.ready()
            log.info("worker %s ready", self.worker_id)
            self._poll()
        finally:
            if self.wake is not None:
                self.wake.close()
            presence.close()
            self.db.dispose()

    def _poll(self) -> None:
        """Claim and run jobs until :meth:`stop`; a failing poll is retried with a capped backoff."""
        backoff = Backoff()
        outage = OutageLog(log, f"worker {self.worker_id} polling the queue")
        while not self.shutdown.is_set():
            try:
                ran = self.run_once()
                backoff.reset()
                outage.succeeded()
            except Exception as error:  # noqa: BLE001 - a worker outlives every failure of one poll
                outage.failed(error)
                self.shutdown.wait(backoff.next())
                continue
            if not ran:
                self.idle()

    def idle(self) -> None:
        """Wait for work: until woken (jobs were queued, :mod:`backend.wakeup`), or ``poll_s`` at most."""
        if self.wake is None:
            self.shutdown.wait(self.settings.poll_s)
        elif not self.shutdown.is_set():
            self.wake.wait(self.settings.poll_s)


def main(settings: Settings | None = None, *, on_ended: Sequence[Ended] = ()) -> None:
    """A worker process (``mgrao worker``, or started by ``mgrao serve``): see :mod:`backend.processes`."""
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    from backend.execution.lifeline import bind_to_supervisor  # started by `mgrao serve`: stop when it dies
    bind_to_supervisor()
    worker = Worker(settings or Settings(), on_ended=on_ended)
    worker.install_signal_handlers()
    worker.serve_forever()

