"""Waits with a deadline: every poll loop and join of the tests ends, saying what it waited for.

A wait without a deadline turns a bug into a CI run that hangs until it is killed, with nothing to
read; :func:`wait_until` fails the one test instead, naming the condition and (``details``) whatever
helps to see why: a service's log, the last value seen.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from typing import TypeVar

T = TypeVar("T")


def wait_until(predicate: Callable[[], T], timeout: float, what: str, *, step: float = 0.1,
               details: Callable[[], str] | None = None) -> T:
    """Call ``predicate`` every ``step`` seconds until it returns something true; that value.

    The predicate is called at least once, and once more at the deadline, so a slow predicate
    (a request, a query) is never cut short by the clock alone. Exceptions from it propagate: a
    predicate that sees a condition that will never come (a job that failed) should raise at once.

    Raises:
        AssertionError: ``timed out after {timeout} s waiting for {what}``, then ``details()``.
    """
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            break
        time.sleep(min(step, max(0.0, deadline - time.monotonic())))
    message = f"timed out after {timeout:g} s waiting for {what}"
    if details is not None:
        message += "\n" + details()
    raise AssertionError(message)


def join_all(threads: Iterable[threading.Thread], timeout: float, what: str) -> None:
    """Join every thread within ``timeout`` seconds in all; start them as daemons, so one that never ends
    fails its test here and does not keep the interpreter from exiting.

    Raises:
        AssertionError: naming ``what`` and how many threads were still running.
    """
    threads = list(threads)
    deadline = time.monotonic() + timeout
    for thread in threads:
        thread.join(max(0.0, deadline - time.monotonic()))
    running = [thread.name for thread in threads if thread.is_alive()]
    assert not running, f"timed out after {timeout:g} s waiting for {what}: {len(running)} thread(s) still running"
