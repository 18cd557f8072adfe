"""A real local Dask cluster for the tests and benchmarks: ``dask scheduler`` and ``dask worker``
processes on 127.0.0.1, started, killed, frozen and stopped by process id."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from mgrao_cli.supervisor import stop_processes
from tests.support.local_service import free_port


def _dask(*args: str) -> list[str]:
    """The argv of ``dask ARGS`` with this interpreter's environment."""
    executable = Path(sys.executable).with_name("dask")
    return [str(executable), *args] if executable.exists() else [sys.executable, "-m", "dask", *args]


class DaskCluster:
    """One scheduler and its workers. ``scheduler_env`` sets Dask's config (e.g. a short worker-ttl)."""

    def __init__(self, log_dir: Path, scheduler_env: dict[str, str] | None = None) -> None:
        self.log_dir = log_dir
        self.port = free_port()
        self.dashboard_port = free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.scheduler: subprocess.Popen | None = None
        self.workers: list[subprocess.Popen] = []
        self.scheduler_env = scheduler_env or {}
        self._logs: list = []

    def _spawn(self, argv: list[str], env: dict[str, str], name: str) -> subprocess.Popen:
        log = open(self.log_dir / f"{name}-{len(self._logs)}.log", "wb")  # noqa: SIM115
        self._logs.append(log)
        return subprocess.Popen(argv, env=env, stdout=log, stderr=subprocess.STDOUT)

    def start_scheduler(self) -> None:
        env = dict(os.environ, **self.scheduler_env)
        self.scheduler = self._spawn(
            _dask("scheduler", "--host", "127.0.0.1", "--port", str(self.port),
                  "--dashboard-address", f"127.0.0.1:{self.dashboard_port}"), env, "scheduler")
        self._wait_port(self.port, "the scheduler")

    def start_worker(self, *, threads: int = 1, memory_limit: str = "0", env: dict[str, str] | None = None) -> None:
        self._worker_options = {"threads": threads, "memory_limit": memory_limit, "env": env}
        environment = dict(os.environ, NUMBA_NUM_THREADS="1", **(env or {}))
        self.workers.append(self._spawn(
            _dask("worker", self.address, "--host", "127.0.0.1", "--nthreads", str(threads), "--nworkers", "1",
                  "--memory-limit", memory_limit, "--no-dashboard", "--death-timeout", "120"),
            environment, "worker"))

    def _wait_port(self, port: int, what: str, timeout: float = 60) -> None:
        import socket

        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            with socket.socket() as probe:
                if probe.connect_ex(("127.0.0.1", port)) == 0:
                    return
            time.sleep(0.1)
        raise RuntimeError(f"{what} did not listen on {port} within {timeout} s\n{self.logs()}")

    def wait_workers(self, count: int, timeout: float = 120) -> dict:
        """Wait until ``count`` workers are connected; their scheduler info, keyed by address."""
        from distributed import Client

        deadline = time.monotonic() + timeout
        with Client(self.address, timeout=30, set_as_default=False) as client:
            while time.monotonic() < deadline:
                workers = client.scheduler_info(n_workers=-1)["workers"]
                if len(workers) >= count:
                    return workers
                time.sleep(0.2)
        raise RuntimeError(f"only {len(workers)} of {count} Dask workers connected\n{self.logs()}")

    def worker_pids(self) -> list[int]:
        """The process ids of the worker processes the scheduler knows (the nannies' children)."""
        from distributed import Client

        with Client(self.address, timeout=30, set_as_default=False) as client:
            return list(client.run(os.getpid).values())

    def restart_scheduler(self) -> None:
        """SIGKILL the scheduler and start a new one on the same address.

        Dask workers close when their scheduler goes away; as a deployment's process manager would
        (``restart: unless-stopped`` in docker-compose.yml), the workers that exited are started again.
        """
        assert self.scheduler is not None
        self.scheduler.send_signal(signal.SIGKILL)
        self.scheduler.wait()
        self.start_scheduler()
        deadline = time.monotonic() + 30
        while any(w.poll() is None for w in self.workers) and time.monotonic() < deadline:
            time.sleep(0.2)
        exited = [w for w in self.workers if w.poll() is not None]
        self.workers = [w for w in self.workers if w.poll() is None]
        for _ in exited:
            self.start_worker(**self._worker_options)

    def stop(self) -> None:
        """SIGTERM the workers, and the scheduler once they have ended.

        Stopped at once, a worker whose scheduler closed in the middle of its own closing hung until its nanny
        killed it, 8 s later (distributed's nanny), in about one teardown of two.
        """
        stop_processes(self.workers, 20)
        stop_processes([self.scheduler] if self.scheduler else [], 20)
        for log in self._logs:
            log.close()

    def logs(self) -> str:
        return "\n".join(p.read_text(errors="replace")[-2000:] for p in sorted(self.log_dir.glob("*.log")))
