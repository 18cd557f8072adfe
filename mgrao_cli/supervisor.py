"""The local workers of ``mgrao serve``: started, watched, restarted with a capped backoff, stopped.

A watcher thread checks the workers every ``CHECK_S`` seconds. A worker that died, whatever the
cause (exit, SIGKILL, SIGSEGV, ...), is logged with its pid and exit status and started again after
a delay that doubles with each quick death in a row (``Backoff``); a worker that ran for
``Backoff.stable_s`` seconds starts the count afresh. Nothing that goes wrong in the watcher
(a failed start, a closed stderr) ends the thread: it logs what it can and keeps watching, and the
API goes on serving throughout.

Workers run ``python -P -m backend.processes`` (no current directory on ``sys.path``) with the
directories that hold the serving process's ``backend`` and ``mgrao_core`` on ``PYTHONPATH``, so
that they run exactly the code ``serve`` imported, never a source tree that happens to be in the
working directory.
"""

from __future__ import annotations

import os
import signal
import site
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass

import click

from backend.execution.lifeline import SUPERVISOR_ENV

CHECK_S = 0.5
STOP_TIMEOUT_S = 30.0


def stop_processes(processes: list[subprocess.Popen], timeout_s: float) -> None:
    """SIGTERM every process at once, wait up to ``timeout_s`` for each, then SIGKILL what is left."""
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
    for process in processes:
        try:
            process.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


@dataclass(frozen=True)
class Backoff:
    """Delay before restarting a worker: ``first_s`` doubled per quick death in a row, at most ``cap_s``."""

    first_s: float = 1.0
    cap_s: float = 30.0
    stable_s: float = 60.0
    """A worker that ran at least this long died of something new: the count starts again."""

    def delay(self, quick_deaths: int) -> float:
        """Seconds to wait after the ``quick_deaths``-th quick death in a row (1, 2, ...)."""
        return min(self.cap_s, self.first_s * 2.0 ** min(max(quick_deaths - 1, 0), 32))


def _say(message: str) -> None:
    """Log to stderr; a closed or broken stderr must not stop the supervisor."""
    try:
        click.echo(f"mgrao: {message}", err=True)
    except (OSError, ValueError):
        pass


def describe_exit(returncode: int) -> str:
    """``exited with status 1`` or ``was killed by SIGSEGV``."""
    if returncode < 0:
        try:
            name = signal.Signals(-returncode).name
        except ValueError:
            name = f"signal {-returncode}"
        return f"was killed by {name}"
    return f"exited with status {returncode}"


def _package_roots() -> list[str]:
    """The directories the serving process imported ``backend`` and ``mgrao_core`` from.

    Site directories are left out: they are on every worker's path already, after the standard
    library (putting them in front of it could let an installed package shadow a standard module).
    """
    import backend
    import mgrao_core

    site_dirs = {os.path.realpath(d) for d in [*site.getsitepackages(), site.getusersitepackages()]}
    roots = []
    for package in (backend, mgrao_core):
        root = os.path.dirname(os.path.dirname(os.path.abspath(package.__file__ or "")))
        if os.path.realpath(root) not in site_dirs and root not in roots:
            roots.append(root)
    return roots


def worker_command() -> list[str]:
    """The argv of one local worker (``-P``: the working directory is not on its ``sys.path``)."""
    return [sys.executable, "-P", "-m", "backend.processes"]


def worker_env(database_url: str, workers: int) -> dict[str, str]:
    """The environment of the local workers of this ``serve`` process."""
    env = dict(os.environ)
    env["MGRAO_DATABASE_URL"] = database_url
    # numba uses every core per process: share the cores between the local workers.
    env["NUMBA_NUM_THREADS"] = str(max(1, (os.cpu_count() or 1) // max(1, workers)))
    env[SUPERVISOR_ENV] = str(os.getpid())  # the worker stops when this process dies
    paths = [*_package_roots(), *[p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p]]
    if paths:
        env["PYTHONPATH"] = os.pathsep.join(dict.fromkeys(paths))
    return env


@dataclass
class _Slot:
    """One of the N worker positions."""

    process: subprocess.Popen | None = None
    started: float = 0.0
    quick_deaths: int = 0
    restart_at: float = 0.0


class WorkerPool:
    """N local worker processes, each restarted when it dies; :meth:`stop` ends them all."""

    def __init__(self, count: int, database_url: str, *, backoff: Backoff | None = None,
                 on_death: Callable[[int, str], list[int]] | None = None) -> None:
        self.env = worker_env(database_url, count)
        self.backoff = backoff or Backoff()
        self.on_death = on_death
        """Told each dead worker's pid and how it ended; gives back the jobs it held (their ids)."""
        self._stopping = threading.Event()
        self._lock = threading.Lock()
        self._slots = [_Slot() for _ in range(count)]
        with self._lock:
            for slot in self._slots:
                self._try_start(slot, time.monotonic())  # from the main thread (see backend/execution/lifeline.py)
        self._watcher = threading.Thread(target=self._watch, name="worker-watch", daemon=True)
        self._watcher.start()

    def _try_start(self, slot: _Slot, now: float) -> None:
        try:
            slot.process = subprocess.Popen(worker_command(), env=self.env)
        except Exception as error:  # e.g. out of processes or memory: try again later
            slot.quick_deaths += 1
            delay = self.backoff.delay(slot.quick_deaths)
            slot.restart_at = now + delay
            _say(f"could not start a worker ({error}); trying again in {delay:g} s")
            return
        slot.started = now
        _say(f"worker {slot.process.pid} started")

    def _watch(self) -> None:
        while not self._stopping.wait(CHECK_S):
            try:
                self.check()
            except Exception:  # the watcher outlives any error; the next check tries again
                _say("worker supervisor error (still watching):\n" + traceback.format_exc().rstrip())

    def check(self) -> None:
        """Notice dead workers and start those whose backoff has passed."""
        with self._lock:
            for slot in self._slots:
                if self._stopping.is_set():
                    return
                now = time.monotonic()
                if slot.process is not None and slot.process.poll() is not None:
                    self._buried(slot, now)
                if slot.process is None and now >= slot.restart_at:
                    self._try_start(slot, now)

    def _buried(self, slot: _Slot, now: float) -> None:
        process = slot.process
        assert process is not None
        lived = now - slot.started
        slot.quick_deaths = slot.quick_deaths + 1 if lived < self.backoff.stable_s else 1
        delay = self.backoff.delay(slot.quick_deaths)
        slot.process, slot.restart_at = None, now + delay
        how = describe_exit(process.returncode)
        _say(f"worker {process.pid} {how} after {lived:.1f} s; restarting it in {delay:g} s")
        if self.on_death is None:
            return
        try:
            handed = self.on_death(process.pid, how)
        except Exception as error:  # the database is away: the jobs go back once their heartbeats are stale
            _say(f"could not hand back worker {process.pid}'s jobs now ({error}); they go back when stale")
            return
        if handed:
            _say(f"worker {process.pid}'s jobs {', '.join(map(str, handed))} handed back to the queue")

    def stop(self) -> None:
        """Stop every worker (each hands its running job back to the queue): SIGTERM, then SIGKILL."""
        self._stopping.set()
        with self._lock:
            stop_processes([s.process for s in self._slots if s.process is not None], STOP_TIMEOUT_S)
