"""What the processes of one test run share: a directory, and set-up done once in it under a file lock.

Under pytest-xdist (``pytest -n``) every worker process runs the ``scope="session"`` fixtures once for
itself (pytest-xdist#271). Set-up that must happen once per run (a migrated template database) is
made by the first process that asks, under a lock in the directory all of them share, and found
there by the others; per-process resources (ports, a PostgreSQL server, a browser) stay each
worker's own, keyed by its ``worker_id`` (see :func:`tests.support.local_service.free_port`).
"""

from __future__ import annotations

import fcntl
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

LOCK_TIMEOUT_S = 1800.0
"""How long a process waits for another's set-up (compiling kernels can take minutes on a loaded machine)."""


def worker_id() -> str:
    """This process's xdist worker (``gw0``, ``gw1``, ...), or ``master`` outside xdist (its ``worker_id`` fixture)."""
    return os.environ.get("PYTEST_XDIST_WORKER", "master")


def run_directory(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The directory every process of this test run shares (xdist's workers' base temp's parent), this run's own."""
    base = tmp_path_factory.getbasetemp()
    return base if worker_id() == "master" else base.parent


@contextmanager
def file_lock(path: Path, what: str, timeout: float = LOCK_TIMEOUT_S) -> Iterator[None]:
    """Hold an exclusive lock on ``path`` (created if absent), waiting at most ``timeout`` seconds for it.

    Raises:
        TimeoutError: naming ``what`` the holder was doing, when the lock is not free in time.
    """
    deadline = time.monotonic() + timeout
    with open(path, "a") as handle:
        while True:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    raise TimeoutError(f"timed out after {timeout:g} s waiting for another test process to "
                                       f"finish {what} (lock {path})") from None
                time.sleep(0.05)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def made_once(directory: Path, name: str, make: Callable[[Path], None], what: str) -> Path:
    """``directory / name``, made by ``make(path)`` in the first process that asks and reused by the others.

    ``make`` writes the path; a marker written after it succeeds tells the others it is complete (a
    process that failed half-way leaves no marker, and the next one makes it again).
    """
    path = directory / name
    done = directory / f"{name}.done"
    with file_lock(directory / f"{name}.lock", what):
        if not done.exists():
            make(path)
            done.touch()
    return path
