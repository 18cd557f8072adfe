"""A local worker process: warm up the engine, then claim and run jobs until told to stop.

A job runs chunk by chunk (every algorithm over a block of seeds, sized by the job memory
budget); each chunk's runs are stored as soon as it completes, so a retried job computes only
what is missing. While a job runs, a heartbeat thread records that the worker is alive and the
job's progress, and notices a cancel (the job's lease is gone), which makes the run's
``should_stop`` True.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import threading
import time
from collections.abc import Callable
from types import FrameType
from typing import TypeVar

from sqlalchemy.exc import SQLAlchemyError

from backend import queue
from backend.db import Database
from backend.settings import Settings

log = logging.getLogger("mgrao.worker")
T = TypeVar("T")


class _Heartbeat(threading.Thread):
    """Heartbeats and progress writes for one claimed job, on a background thread."""

    def __init__(self, db: Database, claim: queue.Claim, settings: Settings, shutdown: threading.Event) -> None:
        super().__init__(name=f"heartbeat-{claim.job_id}", daemon=True)
        self.db, self.claim, self.settings, self.shutdown = db, claim, settings, shutdown
        self.lost = threading.Event()
        self.done = threading.Event()
        self.progress = 0.0
        self._written = 0.0

    def should_stop(self) -> bool:
        """The run's stop check: the job was taken from us (cancel) or the worker is stopping."""
        return self.lost.is_set() or self.shutdown.is_set()

    def on_progress(self, fraction: float) -> None:
        """The run's progress callback (the thread writes it, throttled)."""
        self.progress = fraction

    def run(self) -> None:
        """Beat until the job ends; write progress at most every ``progress_s``."""
        tick = min(self.settings.heartbeat_s, self.settings.progress_s)
        last_beat = time.monotonic()
        while not self.done.wait(tick):
            now = time.monotonic()
            changed = self.progress != self._written
            if not changed and now - last_beat < self.settings.heartbeat_s:
                continue
            try:
                progress = self.progress if changed else None
                if not queue.heartbeat(self.db, claim=self.claim, progress=progress):
                    self.lost.set()
                    return
                self._written, last_beat = progress if changed else self._written, now
            except Exception:  # a busy database must not kill the run; the next beat retries
                log.exception("heartbeat of job %s failed", self.claim.job_id)


class _Backoff:
    """Capped exponential waits between retries of a failing database call."""

    def __init__(self, first: float = 0.25, cap: float = 30.0) -> None:
        self.first, self.cap, self.delay = first, cap, first

    def next(self) -> float:
        """The wait before the next retry (doubling up to the cap)."""
        delay, self.delay = self.delay, min(self.delay * 2, self.cap)
        return delay

    def reset(self) -> None:
        """Back to the first wait after a success."""
        self.delay = self.first


class Worker:
    """Claims queued jobs one at a time and runs them chunk by chunk with :func:`mgrao_core.run_chunk`.

    No database error stops a worker: every call is retried with a capped backoff until it goes
    through or the worker is told to stop; a job whose lease lapses meanwhile is taken over by
    another worker, which resumes it from the chunks already stored.
    """

    def __init__(self, settings: Settings, *, worker_id: str | None = None) -> None:
        self.settings = settings
        self.db = Database(settings.database_url, settings.db_busy_timeout_s)
        self.worker_id = worker_id or f"{socket.gethostname()}:{os.getpid()}"
        self.shutdown = threading.Event()

    def stop(self, *_: object) -> None:
        """Ask the worker to stop (the running job is handed back to the queue)."""
        self.shutdown.set()

    def install_signal_handlers(self) -> None:
        """Stop cleanly on SIGTERM and SIGINT."""
        def handler(_signum: int, _frame: FrameType | None) -> None:
            self.stop()

        signal.signal(signal.SIGTERM, handler)
        signal.signal(signal.SIGINT, handler)

    def warm_up(self) -> None:
        """Load (or compile) the numba engine before claiming jobs."""
        from mgrao_core import make_spec, run_experiment

        run_experiment(make_spec("single", seeds=1, episodes=2))

    def persist(self, call: Callable[[], T], what: str) -> T:
        """``call()``, retried on database errors with a capped backoff until it succeeds.

        Raises:
            WorkerStopping: the worker was told to stop while the database was failing.
        """
        backoff = _Backoff()
        while True:
            try:
                return call()
            except SQLAlchemyError as error:
                if self.shutdown.is_set():
                    raise WorkerStopping(f"stopping while {what} failed: {error}") from error
                delay = backoff.next()
                log.warning("%s failed (%s); retrying in %.2f s", what, _reason(error), delay)
                self.shutdown.wait(delay)

    def run_once(self) -> bool:
        """Claim and run one job; False when the queue was empty."""
        claim = queue.claim(
            self.db, worker_id=self.worker_id, stale_after_s=self.settings.stale_after_s,
            max_attempts=self.settings.max_attempts,
        )
        if claim is None:
            return False
        try:
            self.execute(claim)
        except WorkerStopping as error:
            log.warning("job %s left to its lease: %s", claim.job_id, error)
        return True

    def execute(self, claim: queue.Claim) -> None:
        """Run a claimed job to its end: succeeded, failed, cancelled or handed back."""
        from mgrao_core import Cancelled, MgraoError, NumericalError, plan_chunks, run_chunk, spec_from_dict

        log.info("worker %s runs job %s (attempt %s)", self.worker_id, claim.job_id, claim.attempt)
        budget = self.settings.job_memory_bytes
        beat = _Heartbeat(self.db, claim, self.settings, self.shutdown)
        beat.start()
        try:
            spec = spec_from_dict(claim.config, memory_budget=budget)
            done = self.persist(lambda: self._stored_seeds(claim.job_id, len(spec.algorithms)), "reading stored runs")
            missing = tuple(seed for seed in spec.seeds if seed not in done)
            finished = len(spec.seeds) - len(missing)
            for chunk in plan_chunks(spec, missing, budget=budget):
                def progress(fraction: float, chunk: tuple[int, ...] = chunk, finished: int = finished) -> None:
                    beat.on_progress((finished + fraction * len(chunk)) / len(spec.seeds))

                runs = run_chunk(spec, chunk, on_progress=progress, should_stop=beat.should_stop)
                rows = queue.run_rows(claim.job_id, runs)
                del runs
                finished += len(chunk)
                stored = self.persist(
                    lambda rows=rows, finished=finished: queue.store_runs(
                        self.db, claim=claim, rows=rows, progress=finished / len(spec.seeds)),
                    f"storing runs of job {claim.job_id}",
                )
                del rows
                if not stored:
                    log.info("job %s was cancelled or taken over; stopped", claim.job_id)
                    return
            expected = len(spec.seeds) * len(spec.algorithms)
            if not self.persist(lambda: queue.finish(self.db, claim=claim, expected_runs=expected),
                                f"finishing job {claim.job_id}"):
                log.info("job %s was cancelled or taken over before it finished", claim.job_id)
        except Cancelled:
            if not beat.lost.is_set():
                self.persist(lambda: queue.release(self.db, claim=claim), f"handing back job {claim.job_id}")
        except NumericalError as error:
            self._fail(claim, str(error), discard_runs=True)
        except MgraoError as error:
            self._fail(claim, str(error))
        except WorkerStopping:
            raise
        except Exception as error:
            log.exception("job %s failed", claim.job_id)
            self._fail(claim, f"{type(error).__name__}: {error}")
        finally:
            beat.done.set()
            beat.join()

    def _fail(self, claim: queue.Claim, message: str, discard_runs: bool = False) -> None:
        self.persist(lambda: queue.fail(self.db, claim=claim, error=message, discard_runs=discard_runs),
                     f"failing job {claim.job_id}")

    def _stored_seeds(self, job_id: int, algorithms: int) -> set[int]:
        with self.db.session() as session:
            return queue.stored_seeds(session, job_id=job_id, algorithms=algorithms)

    def serve_forever(self, *, warm_up: bool = True) -> None:
        """Migrate, warm up, then run jobs until :meth:`stop`; database errors are waited out."""
        try:
            self.persist(self.db.migrate, "migrating the database")
        except WorkerStopping:
            return
        if warm_up:
            self.warm_up()
        log.info("worker %s ready", self.worker_id)
        backoff = _Backoff()
        try:
            while not self.shutdown.is_set():
                try:
                    ran = self.run_once()
                    backoff.reset()
                except Exception as error:  # noqa: BLE001 - a worker outlives every failure of one poll
                    delay = backoff.next()
                    log.warning("polling the queue failed (%s); retrying in %.2f s", _reason(error), delay)
                    self.shutdown.wait(delay)
                    continue
                if not ran:
                    self.shutdown.wait(self.settings.poll_s)
        finally:
            self.db.dispose()


class WorkerStopping(Exception):
    """The worker was told to stop while a database call was still failing."""


def _reason(error: BaseException) -> str:
    text = str(getattr(error, "orig", None) or error).strip().splitlines()
    return text[0] if text else type(error).__name__


def main(settings: Settings | None = None) -> None:
    """Entry point of a worker process (``mgrao worker``, or started by ``mgrao serve``)."""
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    from backend.lifeline import bind_to_supervisor  # started by `mgrao serve`: stop when it dies
    bind_to_supervisor()
    worker = Worker(settings or Settings())
    worker.install_signal_handlers()
    worker.serve_forever()


if __name__ == "__main__":
    main()
