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
import socket
import threading
from collections.abc import Callable
from typing import TypeVar

from backend import queue, studies
from backend.db import Database
from backend.heartbeats import Heartbeats
from backend.lifeline import stop_on_signals
from backend.presence import Presence, refresh_interval
from backend.retry import Backoff, HealthClock, OutageLog, Stopping, persist
from backend.settings import Settings

log = logging.getLogger("mgrao.worker")
T = TypeVar("T")


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
        self.health = HealthClock()

    def stop(self, *_: object) -> None:
        """Ask the worker to stop (the running job is handed back to the queue)."""
        self.shutdown.set()

    def install_signal_handlers(self) -> None:
        """Stop cleanly on SIGTERM and SIGINT."""
        stop_on_signals(self.stop)

    def warm_up(self) -> None:
        """Load (or compile) the numba engine before claiming jobs."""
        from mgrao_core import make_spec, run_experiment

        run_experiment(make_spec("single", seeds=1, episodes=2))

    def persist(self, call: Callable[[], T], what: str) -> T:
        """``call()``, retried on database errors until it succeeds (see :mod:`backend.retry`)."""
        return persist(call, what, self.shutdown, self.health)

    def run_once(self) -> bool:
        """Claim and run one job; False when the queue was empty."""
        try:
            claim = queue.claim(
                self.db, worker_id=self.worker_id, stale_after_s=self.settings.stale_after_s,
                max_attempts=self.settings.max_attempts, requeue=self.health.steady_for(self.settings.stale_after_s),
            )
        except Exception:
            self.health.failure()
            raise
        self.health.success()
        if claim is None:
            return False
        try:
            self.execute(claim)
        except Stopping as error:
            log.warning("job %s left to its lease: %s", claim.job_id, error)
        return True

    def execute(self, claim: queue.Claim) -> None:
        """Run a claimed job to its end: succeeded, failed, cancelled or handed back."""
        from mgrao_core import Cancelled, MgraoError, NumericalError, plan_chunks, run_chunk, spec_from_dict

        log.info("worker %s runs job %s (attempt %s)", self.worker_id, claim.job_id, claim.attempt)
        budget = self.settings.job_memory_bytes
        beats = Heartbeats(self.db, heartbeat_s=self.settings.heartbeat_s, progress_s=self.settings.progress_s,
                           name=f"heartbeat-{claim.job_id}", health=self.health)
        beats.add(claim)
        beats.start()

        def should_stop() -> bool:  # the job was taken from us (cancel) or the worker is stopping
            return beats.lost(claim.job_id) or self.shutdown.is_set()

        try:
            spec = spec_from_dict(claim.config, memory_budget=budget)
            done = self.persist(lambda: self._stored_seeds(claim.job_id, len(spec.algorithms)), "reading stored runs")
            missing = tuple(seed for seed in spec.seeds if seed not in done)
            finished = len(spec.seeds) - len(missing)
            for chunk in plan_chunks(spec, missing, budget=budget):
                def progress(fraction: float, chunk: tuple[int, ...] = chunk, finished: int = finished) -> None:
                    beats.set_progress(claim.job_id, (finished + fraction * len(chunk)) / len(spec.seeds))

                runs = run_chunk(spec, chunk, on_progress=progress, should_stop=should_stop)
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
            if not beats.lost(claim.job_id):
                self.persist(lambda: queue.release(self.db, claim=claim), f"handing back job {claim.job_id}")
        except NumericalError as error:
            self._fail(claim, str(error), discard_runs=True)
        except MgraoError as error:
            self._fail(claim, str(error))
        except Stopping:
            raise
        except Exception as error:
            log.exception("job %s failed", claim.job_id)
            self._fail(claim, f"{type(error).__name__}: {error}")
        finally:
            beats.close()
        studies.advance_after(self.db, claim.job_id)

    def _fail(self, claim: queue.Claim, message: str, discard_runs: bool = False) -> None:
        self.persist(lambda: queue.fail(self.db, claim=claim, error=message, discard_runs=discard_runs),
                     f"failing job {claim.job_id}")

    def _stored_seeds(self, job_id: int, algorithms: int) -> set[int]:
        with self.db.session() as session:
            return queue.stored_seeds(session, job_id=job_id, algorithms=algorithms)

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
            presence.ready()
            log.info("worker %s ready", self.worker_id)
            self._poll()
        finally:
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
                self.shutdown.wait(self.settings.poll_s)


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
