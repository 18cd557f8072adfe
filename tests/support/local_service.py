"""Start, wait for and stop a real ``mgrao serve`` process on 127.0.0.1.

Used by the backend and dashboard tests and by the service and dashboard benchmarks, so that all
of them start the service the same way and stop what they start.
"""

from __future__ import annotations

import itertools
import os
import random
import socket
import subprocess
import sys
import time
import urllib.request

from mgrao_cli.supervisor import stop_processes

PORTS_PER_WORKER = 1000
FIRST_WORKER_PORT = 20000
"""The ports of xdist worker ``gwN``: ``FIRST_WORKER_PORT + N * PORTS_PER_WORKER`` and the next 999, below Linux's
ephemeral range (32768-60999), where ``bind(0)`` and outgoing connections draw theirs."""
WORKER_RANGES = 12
_next = itertools.count(random.randrange(PORTS_PER_WORKER))


def _bindable(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now.

    Outside pytest-xdist, one the kernel picks (``bind(0)``). In xdist worker ``gwN`` (its ``worker_id``),
    one of that worker's own range (:data:`PORTS_PER_WORKER` ports), never the same twice in a row: a port
    picked and closed here stays free until the server it is for binds it, and two workers picking at once
    (one for its PostgreSQL server, the other for an ``mgrao serve``) could otherwise be given the same one.
    """
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")
    if not worker.startswith("gw") or not worker[2:].isdigit():
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            return s.getsockname()[1]
    first = FIRST_WORKER_PORT + int(worker[2:]) % WORKER_RANGES * PORTS_PER_WORKER
    for _ in range(PORTS_PER_WORKER):
        port = first + next(_next) % PORTS_PER_WORKER
        if _bindable(port):
            return port
    raise RuntimeError(f"no free port in {first}-{first + PORTS_PER_WORKER - 1} (xdist worker {worker})")


def mgrao_command(*args: str) -> list[str]:
    """The argv that runs ``mgrao ARGS`` with this interpreter (no reliance on PATH)."""
    return [sys.executable, "-m", "mgrao_cli", *args]


def serve_command(port: int, workers: int, database_url: str | None = None) -> list[str]:
    """The argv of ``mgrao serve`` on 127.0.0.1:``port`` with ``workers`` local workers."""
    args = ["serve", "--host", "127.0.0.1", "--port", str(port), "--workers", str(workers)]
    if database_url is not None:
        args += ["--database-url", database_url]
    return mgrao_command(*args)


def wait_healthy(base: str, process: subprocess.Popen | None = None, timeout: float = 60.0) -> None:
    """Wait until ``{base}/api/health`` answers 200.

    Raises:
        RuntimeError: ``process`` exited first, or the deadline passed.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if process is not None and process.poll() is not None:
            raise RuntimeError(f"mgrao serve exited with {process.returncode}")
        try:
            with urllib.request.urlopen(f"{base}/api/health", timeout=2) as response:
                if response.status == 200:
                    return
        except OSError:
            pass
        time.sleep(0.1)
    raise RuntimeError(f"{base}/api/health did not answer within {timeout} s")


def stop(process: subprocess.Popen, timeout: float = 30.0) -> None:
    """SIGTERM the process, wait up to ``timeout`` seconds, then SIGKILL it."""
    stop_processes([process], timeout)
