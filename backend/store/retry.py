"""Database calls of long-lived processes (workers, the dispatcher), retried until they go through.

A worker or dispatcher must outlive every database fault (read-only, locked, unreachable for a
while): each call is retried with a capped exponential backoff until it succeeds or the process
is told to stop. The cap (:data:`RETRY_CAP_S`) is short, so work resumes about that long after the
database returns; an outage is logged once when it starts and once when it ends
(:class:`OutageLog`), however many tries it takes.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import TypeVar

from sqlalchemy.exc import SQLAlchemyError

from backend.store.dialect import DatabaseUnavailable, reason

T = TypeVar("T")
log = logging.getLogger("mgrao.retry")
RETRY_CAP_S = 2.0
"""The longest wait between two tries of a failing database call: work resumes at most this long
after the database returns (a try is one cheap query, so trying this often costs the database nothing)."""


class Backoff:
    """Capped exponential waits between retries."""

    def __init__(self, first: float = 0.25, cap: float = RETRY_CAP_S) -> None:
        self.first, self.cap, self.delay = first, cap, first

    def next(self) -> float:
        """The wait before the next retry (doubling up to the cap)."""
        delay, self.delay = self.delay, min(self.delay * 2, self.cap)
        return delay

    def reset(self) -> None:
        """Back to the first wait after a success."""
        self.delay = self.first


class HealthClock:
    """Since when this process has seen the database answer without a failure.

    During a database outage every heartbeat stops, the live workers' as well as a dead one's; a
    heartbeat that is old only because of the outage must not cost its job an attempt. So a
    process judges others' heartbeats stale only once it has itself seen the database healthy for
    the staleness period (:meth:`steady_for`): by then every live worker has beaten again.
    """

    def __init__(self) -> None:
        self._since: float | None = None
        self._lock = threading.Lock()

    def success(self) -> None:
        """A database call went through."""
        with self._lock:
            if self._since is None:
                self._since = time.monotonic()

    def failure(self) -> None:
        """A database call failed."""
        with self._lock:
            self._since = None

    def steady_for(self, seconds: float) -> bool:
        """Whether every database call of the last ``seconds`` went through."""
        with self._lock:
            return self._since is not None and time.monotonic() - self._since >= seconds


class OutageLog:
    """Logs a repeated call's failures as one line when they start and one when the call goes through again.

    A loop that retries every :data:`RETRY_CAP_S` through a database outage would otherwise log (and,
    with a traceback, fill the log) at every try. A failure that is not the database's own (a bug)
    carries its traceback, once.
    """

    def __init__(self, logger: logging.Logger, what: str) -> None:
        self.logger, self.what = logger, what
        self.failures = 0
        self.since = 0.0

    def failed(self, error: BaseException) -> None:
        """A try failed: a warning if it is the first of a run of failures, else a debug line."""
        self.failures += 1
        if self.failures > 1:
            self.logger.debug("%s failed again (%s)", self.what, reason(error))
            return
        self.since = time.monotonic()
        ours = isinstance(error, SQLAlchemyError | DatabaseUnavailable)
        self.logger.warning("%s failed (%s); retrying at least every %g s, logged again when it goes through",
                            self.what, reason(error), RETRY_CAP_S, exc_info=None if ours else error)

    def succeeded(self) -> None:
        """A try went through: one line if it ends a run of failures."""
        if self.failures:
            self.logger.warning("%s goes through again after %.1f s and %d failed tries", self.what,
                                time.monotonic() - self.since, self.failures)
            self.failures = 0


class Stopping(Exception):
    """The process was told to stop while a database call was still failing."""


def persist(call: Callable[[], T], what: str, stop: threading.Event, health: HealthClock | None = None) -> T:
    """``call()``, retried on database errors with a capped backoff until it succeeds.

    Raises:
        Stopping: ``stop`` was set while the database was failing.
    """
    backoff = Backoff()
    outage = OutageLog(log, what)
    while True:
        try:
            value = call()
        except (SQLAlchemyError, DatabaseUnavailable) as error:
            if health is not None:
                health.failure()
            if stop.is_set():
                raise Stopping(f"stopping while {what} failed: {reason(error)}") from error
            outage.failed(error)
            stop.wait(backoff.next())
        else:
            if health is not None:
                health.success()
            outage.succeeded()
            return value
