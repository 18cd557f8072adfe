"""Which workers are alive, and whether they are still warming up: the ``workers`` table.

Every local worker process (and the Dask dispatcher) keeps one row: its id, its kind, its state
(``warming`` while it loads or compiles the simulation kernel, about 20 s on a fresh install;
``ready`` once it can run a job) and when it was last seen, by the database clock. A thread
refreshes the row (:func:`refresh_interval`: four times per ``stale_after_s``, busy or idle) and
at once when the state changes; a clean stop deletes it; the row of a killed
process stops being refreshed and no longer counts after ``stale_after_s`` (the same age after
which its job is re-queued), and the next process to start deletes rows older than
:data:`FORGET_AFTER_S`. :func:`counts` is what ``/api/health`` reports. Nothing here touches a
job: a database error only delays the next refresh.
"""

from __future__ import annotations

import logging
import threading

from sqlalchemy import delete, func, insert, select, update
from sqlalchemy.orm import Session

from backend.settings import Settings
from backend.store.db import Database
from backend.store.dialect import db_now, reason
from backend.store.models import READY, WARMING, WORKER_STATES, WorkerPresence
from backend.store.retry import OutageLog

log = logging.getLogger("mgrao.presence")

FORGET_AFTER_S = 3600.0
"""Rows of processes unseen for this long are deleted when another process starts."""


def refresh_interval(settings: Settings) -> float:
    """Seconds between refreshes: four per staleness window, never more often than the heartbeat.

    Each refresh is a write: on SQLite it takes the database's one write lock for a moment, and a
    process frozen inside it (SIGSTOP, a debugger) holds that lock until it resumes or dies, so
    idle workers write as seldom as their row's freshness allows.
    """
    return max(settings.heartbeat_s, settings.stale_after_s / 4)


class Presence(threading.Thread):
    """Keeps ``worker_id``'s row while the process lives: call :meth:`ready`, then :meth:`close`."""

    def __init__(self, db: Database, worker_id: str, *, kind: str, interval_s: float) -> None:
        super().__init__(name=f"presence-{worker_id}", daemon=True)
        self.db, self.worker_id, self.kind, self.interval_s = db, worker_id, kind, interval_s
        self.state = WARMING
        self.outage = OutageLog(log, f"refreshing worker {worker_id} in the workers table")
        self._closed = threading.Event()
        self._wake = threading.Event()

    def ready(self) -> None:
        """The kernel is loaded: say so now rather than at the next refresh (once; later calls do nothing)."""
        if self.state != READY:
            self.state = READY
            self._wake.set()

    def close(self) -> None:
        """Stop refreshing and delete the row (a failing database leaves it to go stale)."""
        self._closed.set()
        self._wake.set()
        if self.is_alive():
            self.join()
        try:
            with self.db.write() as session:
                session.execute(delete(WorkerPresence).where(WorkerPresence.worker_id == self.worker_id))
        except Exception as error:  # noqa: BLE001 - a stopping process cannot wait for the database
            log.warning("could not remove worker %s from the workers table (%s)", self.worker_id, reason(error))

    def run(self) -> None:
        """Write the row now, then every ``interval_s`` and whenever the state changes, until closed."""
        self._forget_the_long_gone()
        while not self._closed.is_set():
            self._write()
            self._wake.wait(self.interval_s)
            self._wake.clear()

    def _write(self) -> None:
        try:
            with self.db.write() as session:
                now = db_now(session)
                updated = session.execute(update(WorkerPresence).where(WorkerPresence.worker_id == self.worker_id)
                                          .values(state=self.state, seen_at=now)).rowcount
                if not updated:
                    session.execute(insert(WorkerPresence).values(worker_id=self.worker_id, kind=self.kind,
                                                                  state=self.state, started_at=now, seen_at=now))
        except Exception as error:  # noqa: BLE001 - presence is advisory: retried at the next refresh
            self.outage.failed(error)
        else:
            self.outage.succeeded()

    def _forget_the_long_gone(self) -> None:
        try:
            with self.db.write() as session:
                session.execute(delete(WorkerPresence)
                                .where(WorkerPresence.seen_at < db_now(session, minus_seconds=FORGET_AFTER_S)))
        except Exception as error:  # noqa: BLE001 - housekeeping only
            log.warning("could not forget stale workers (%s)", reason(error))


def counts(session: Session, *, stale_after_s: float) -> dict[str, int]:
    """Workers seen within ``stale_after_s``, per state (``warming``, ``ready``)."""
    rows = session.execute(select(WorkerPresence.state, func.count())
                           .where(WorkerPresence.seen_at >= db_now(session, minus_seconds=stale_after_s))
                           .group_by(WorkerPresence.state)).all()
    return {state: 0 for state in WORKER_STATES} | {state: n for state, n in rows}
