"""``mgrao serve`` (API, dashboard and local workers) and ``mgrao worker`` (one worker alone)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from types import FrameType

import click

WORKER_STOP_TIMEOUT_S = 30.0
WORKER_CHECK_S = 2.0


def _worker_env(database_url: str, workers: int) -> dict[str, str]:
    env = dict(os.environ)
    env["MGRAO_DATABASE_URL"] = database_url
    # numba uses every core per process: share the cores between the local workers.
    env["NUMBA_NUM_THREADS"] = str(max(1, (os.cpu_count() or 1) // max(1, workers)))
    return env


class _Workers:
    """N local worker processes, restarted if one dies, stopped with SIGTERM (then SIGKILL)."""

    def __init__(self, count: int, database_url: str) -> None:
        self.env = _worker_env(database_url, count)
        self.processes = [self._spawn() for _ in range(count)]
        self.stopping = threading.Event()
        self.lock = threading.Lock()
        self.watcher = threading.Thread(target=self._watch, name="worker-watch", daemon=True)
        self.watcher.start()

    def _spawn(self) -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-m", "backend.worker"], env=self.env)

    def _watch(self) -> None:
        while not self.stopping.wait(WORKER_CHECK_S):
            with self.lock:
                for i, process in enumerate(self.processes):
                    if process.poll() is not None and not self.stopping.is_set():
                        click.echo(f"mgrao: worker {process.pid} exited ({process.returncode}); restarting",
                                   err=True)
                        self.processes[i] = self._spawn()

    def stop(self) -> None:
        """Stop every worker (each hands its running job back to the queue)."""
        self.stopping.set()
        with self.lock:
            _stop_processes(self.processes)


def _stop_processes(processes: list[subprocess.Popen]) -> None:
    for process in processes:
        if process.poll() is None:
            process.send_signal(signal.SIGTERM)
    for process in processes:
        try:
            process.wait(timeout=WORKER_STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


def _server_class() -> type:
    import uvicorn

    class Server(uvicorn.Server):
        """uvicorn's server, leaving SIGINT and SIGTERM to ``serve`` (which also stops the workers)."""

        @contextlib.contextmanager
        def capture_signals(self) -> Iterator[None]:
            yield

    return Server


@click.command()
@click.option("--host", default=None, help="Interface to bind (default 127.0.0.1, or MGRAO_HOST).")
@click.option("--port", type=click.IntRange(0, 65535), default=None, help="Port (default 8000, or MGRAO_PORT).")
@click.option("--workers", type=click.IntRange(0, 64), default=None,
              help="Local worker processes (default 1, or MGRAO_WORKERS).")
@click.option("--database-url", default=None, help="SQLAlchemy URL (default sqlite:///./mgrao.db).")
def serve(host: str | None, port: int | None, workers: int | None, database_url: str | None) -> None:
    """Serve the REST API and the dashboard, with local workers running the queued jobs."""
    import uvicorn

    from backend.app import create_app
    from backend.db import Database
    from backend.settings import Settings

    overrides = {k: v for k, v in
                 {"host": host, "port": port, "workers": workers, "database_url": database_url}.items()
                 if v is not None}
    settings = Settings(**overrides)
    _Server = _server_class()  # noqa: N806
    db = Database(settings.database_url)
    db.migrate()  # once, before the workers and the API start
    db.dispose()

    server = _Server(uvicorn.Config(create_app(settings), host=settings.host, port=settings.port,
                                    log_level="info"))

    def on_signal(_signum: int, _frame: FrameType | None) -> None:
        server.should_exit = True

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    pool = _Workers(settings.workers, settings.database_url)
    click.echo(f"mgrao: http://{settings.host}:{settings.port}/ with {settings.workers} worker(s), "
               f"database {settings.database_url}", err=True)
    try:
        server.run()
    finally:
        pool.stop()
    click.echo("mgrao: stopped", err=True)


@click.command()
@click.option("--database-url", default=None, help="SQLAlchemy URL (default MGRAO_DATABASE_URL).")
def worker(database_url: str | None) -> None:
    """Run one worker against the database until Ctrl-C or SIGTERM."""
    from backend.settings import Settings
    from backend.worker import main

    main(Settings(database_url=database_url) if database_url else Settings())
