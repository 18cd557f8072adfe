"""Database calls of long-lived processes (workers, the dispatcher), retried until they go through.

A worker or dispatcher must outlive every database fault (read-only, locked, unreachable for a
while): each call is retried with a capped exponential backoff until it succeeds or the process
is told to stop.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import TypeVar

from sqlalchemy.exc import SQLAlchemyError

from backend.dialect import reason

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


class Stopping(Exception):
    """The process was told to stop while a database call was still failing."""


def persist(call: Callable[[], T], what: str, stop: threading.Event) -> T:
    """``call()``, retried on database errors with a capped backoff until it succeeds.

    Raises:
        Stopping: ``stop`` was set while the database was failing.
    """
    backoff = Backoff()
    while True:
        try:
            return call()
        except SQLAlchemyError as error:
            if stop.is_set():
                raise Stopping(f"stopping while {what} failed: {reason(error)}") from error
            delay = backoff.next()
            log.warning("%s failed (%s); retrying in %.2f s", what, reason(error), delay)
            stop.wait(delay)
