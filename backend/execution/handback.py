"""A local worker's jobs handed back to the queue the moment its supervisor sees it exit.

A worker that dies (SIGKILL, a crash, out of memory) leaves its jobs running under its id, leased to it. Any
worker would take them over once their heartbeats are ``MGRAO_STALE_AFTER_S`` old (60 s by default); the
supervisor of ``mgrao serve`` knows at once, so it re-queues them at once
(:func:`backend.store.queue.requeue_of_worker`, conditional on each job's lease and worker, counting the
attempt that died) and wakes the other workers. Each
job then resumes from the chunks already stored, as after any hand-back: nothing is stored twice.
"""

from __future__ import annotations

import logging
import socket

from backend import wakeup
from backend.settings import Settings
from backend.store import queue
from backend.store.db import Database

log = logging.getLogger("mgrao.handback")


def local_worker_id(pid: int) -> str:
    """The id a worker process of this machine claims jobs under: ``host:pid``."""
    return f"{socket.gethostname()}:{pid}"


class HandBack:
    """Re-queues the jobs of dead local workers, on the database of ``settings`` (opened on first use)."""

    def __init__(self, settings: Settings) -> None:
        self.settings = settings
        self._db: Database | None = None

    def __call__(self, pid: int, how: str) -> list[int]:
        """Re-queue what worker ``pid`` held when it ended (``how``: "was killed by SIGKILL"); the ids re-queued."""
        if self._db is None:
            self._db = Database(self.settings.database_url, self.settings.db_busy_timeout_s)
        with self._db.write() as session:
            ids = queue.requeue_of_worker(session, worker_id=local_worker_id(pid), how=how,
                                          max_attempts=self.settings.max_attempts)
        if ids:
            wakeup.wake_workers()
        return ids

    def close(self) -> None:
        """Release the database connections."""
        if self._db is not None:
            self._db.dispose()
