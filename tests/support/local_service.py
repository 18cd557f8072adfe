"""Start, wait for and stop a real ``mgrao serve`` process on 127.0.0.1.

Used by the backend and dashboard tests and by the service and dashboard benchmarks, so that all
of them start the service the same way and stop what they start.
"""

from __future__ import annotations

import socket
import subprocess
import sys
import time
import urllib.request

from mgrao_cli.supervisor import stop_processes


def free_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


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
