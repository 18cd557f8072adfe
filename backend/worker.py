"""A local worker process: warm up the engine, then claim and run jobs until told to stop.

While a job runs, a heartbeat thread records that the worker is alive and the job's progress,
and notices a cancel (the job's lease is gone), which makes the run's ``should_stop`` True.
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import threading
import time
from types import FrameType

from backend import queue
from backend.db import Database
from backend.settings import Settings

log = logging.getLogger("mgrao.worker")


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


class Worker:
    """Claims queued jobs one at a time and runs them with :func:`mgrao_core.run_experiment`."""

    def __init__(self, settings: Settings, *, worker_id: str | None = None) -> None:
        self.settings = settings
        self.db = Database(settings.database_url)
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

    def run_once(self) -> bool:
        """Claim and run one job; False when the queue was empty."""
        claim = queue.claim(
            self.db, worker_id=self.worker_id, stale_after_s=self.settings.stale_after_s,
            max_attempts=self.settings.max_attempts,
        )
        if claim is None:
            return False
        self.execute(claim)
        return True

    def execute(self, claim: queue.Claim) -> None:
        """Run a claimed job to its end: succeeded, failed, cancelled or handed back."""
        from mgrao_core import Cancelled, MgraoError, run_experiment, spec_from_dict

        log.info("worker %s runs job %s (attempt %s)", self.worker_id, claim.job_id, claim.attempt)
        beat = _Heartbeat(self.db, claim, self.settings, self.shutdown)
        beat.start()
        try:
            spec = spec_from_dict(claim.config)
            result = run_experiment(spec, on_progress=beat.on_progress, should_stop=beat.should_stop)
        except Cancelled:
            if not beat.lost.is_set():
                queue.release(self.db, claim=claim)
            return
        except MgraoError as error:
            queue.fail(self.db, claim=claim, error=str(error))
            return
        except Exception as error:
            log.exception("job %s failed", claim.job_id)
            queue.fail(self.db, claim=claim, error=f"{type(error).__name__}: {error}")
            return
        finally:
            beat.done.set()
            beat.join()
        if not queue.finish(self.db, claim=claim, result=result):
            log.info("job %s was cancelled or taken over; its results were discarded", claim.job_id)

    def serve_forever(self, *, warm_up: bool = True) -> None:
        """Migrate, warm up, then run jobs until :meth:`stop`."""
        self.db.migrate()
        if warm_up:
            self.warm_up()
        log.info("worker %s ready", self.worker_id)
        try:
            while not self.shutdown.is_set():
                if not self.run_once():
                    self.shutdown.wait(self.settings.poll_s)
        finally:
            self.db.dispose()


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
