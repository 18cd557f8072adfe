"""Database calls of long-lived processes (workers, the dispatcher), retried until they go through.

A worker or dispatcher must outlive every database fault (read-only, locked, unreachable for a
while): each call is retried with a capped exponential backoff until it succeeds or the process
is told to stop.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import TypeVar

from sqlalchemy.exc import SQLAlchemyError

from backend.dialect import DatabaseUnavailable, reason

T = TypeVar("T")
log = logging.getLogger("mgrao.retry")


class Backoff:
    """Capped exponential waits between retries."""

    def __init__(self, first: float = 0.25, cap: float = 30.0) -> None:
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


class Stopping(Exception):
    """The process was told to stop while a database call was still failing."""


def persist(call: Callable[[], T], what: str, stop: threading.Event, health: HealthClock | None = None) -> T:
    """``call()``, retried on database errors with a capped backoff until it succeeds.

    Raises:
        Stopping: ``stop`` was set while the database was failing.
    """
    backoff = Backoff()
    while True:
        try:
            value = call()
        except (SQLAlchemyError, DatabaseUnavailable) as error:
            if health is not None:
                health.failure()
            if stop.is_set():
                raise Stopping(f"stopping while {what} failed: {reason(error)}") from error
            delay = backoff.next()
            log.warning("%s failed (%s); retrying in %.2f s", what, reason(error), delay)
            stop.wait(delay)
        else:
            if health is not None:
                health.success()
            return value
