"""``mgrao serve`` (API, dashboard and local workers) and ``mgrao worker`` (one worker alone)."""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
import socket
from collections.abc import Iterator
from types import FrameType
from typing import Any

import click

from mgrao_cli.supervisor import WorkerPool

LISTEN_BACKLOG = 2048  # uvicorn's default


def listen(host: str, port: int) -> socket.socket:
    """A listening TCP socket on ``host:port``, as uvicorn would bind it.

    ``serve`` binds before anything else (migrations, workers) and hands the socket to uvicorn, so a
    busy port fails at once and nothing can take the port between the check and the start.

    Raises:
        click.ClickException: the port is in use, or the address cannot be bound.
    """
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    # IPPROTO_TCP, not 0: asyncio sets TCP_NODELAY only on accepted sockets whose proto says TCP, and an
    # accepted socket takes the listening one's. Without it every keep-alive request waited for the
    # client's delayed ACK (about 40 ms) between the response's header and body writes.
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(LISTEN_BACKLOG)
    except OSError as error:
        sock.close()
        if error.errno == errno.EADDRINUSE:
            raise click.ClickException(f"port {port} on {host} is in use (choose another with --port)") from None
        raise click.ClickException(f"cannot listen on {host} port {port}: {error.strerror or error}") from None
    return sock


def settings_or_exit(settings_class: type, overrides: dict[str, object]) -> Any:
    """``settings_class(**overrides)``, or a one-line error per refused setting (exit status 1, no traceback).

    Raises:
        click.ClickException: a setting is invalid, e.g. ``MGRAO_PROTECT_READS=true`` without
            ``MGRAO_API_TOKEN``.
    """
    from pydantic import ValidationError

    try:
        return settings_class(**overrides)
    except ValidationError as error:
        lines = []
        for item in error.errors():
            message = str(item.get("msg", "invalid")).removeprefix("Value error, ")
            where = ".".join(str(part) for part in item.get("loc", ()))
            lines.append(f"MGRAO_{where.upper()}: {message}" if where else message)
        raise click.ClickException("invalid settings: " + "; ".join(lines)) from None


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

    from backend import wakeup
    from backend.api.app import create_app
    from backend.settings import Settings
    from backend.store.db import Database

    overrides = {k: v for k, v in
                 {"host": host, "port": port, "workers": workers, "database_url": database_url}.items()
                 if v is not None}
    settings = settings_or_exit(Settings, overrides)
    wake_dir = None
    if not os.environ.get(wakeup.ENV):  # wake-ups between the API and its workers (backend/wakeup.py)
        wake_dir = wakeup.make_directory()
        os.environ[wakeup.ENV] = str(wake_dir)  # read by the API here and inherited by the workers
    sock = listen(settings.host, settings.port)  # first: a busy port fails before anything starts
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
    from backend.execution.handback import HandBack

    hand_back = HandBack(settings)
    pool = WorkerPool(settings.workers, settings.database_url, on_death=hand_back)
    port = sock.getsockname()[1]
    url_host = f"[{settings.host}]" if ":" in settings.host else settings.host
    click.echo(f"mgrao: http://{url_host}:{port}/ with {settings.workers} worker(s), "
               f"database {settings.database_url}", err=True)
    try:
        server.run(sockets=[sock])
    finally:
        pool.stop()
        hand_back.close()
        if wake_dir is not None:
            shutil.rmtree(wake_dir, ignore_errors=True)
    click.echo("mgrao: stopped", err=True)


@click.command()
@click.option("--database-url", default=None, help="SQLAlchemy URL (default MGRAO_DATABASE_URL).")
def worker(database_url: str | None) -> None:
    """Run one worker against the database until Ctrl-C or SIGTERM."""
    from backend.processes import run_worker
    from backend.settings import Settings

    run_worker(Settings(database_url=database_url) if database_url else Settings())


@click.command()
@click.option("--dask", "address", default=None, metavar="ADDRESS",
              help="The Dask scheduler, e.g. tcp://scheduler:8786 (default MGRAO_DASK_ADDRESS).")
@click.option("--database-url", default=None, help="SQLAlchemy URL (default MGRAO_DATABASE_URL).")
def dispatcher(address: str | None, database_url: str | None) -> None:
    """Claim queued jobs and run their chunks on a Dask cluster until Ctrl-C or SIGTERM."""
    from backend.processes import run_dispatcher
    from backend.settings import Settings

    settings = Settings(database_url=database_url) if database_url else Settings()
    if not (address or settings.dask_address):
        raise click.UsageError("give the Dask scheduler's address with --dask or MGRAO_DASK_ADDRESS")
    run_dispatcher(settings, address)


@click.command()
@click.option("--database-url", default=None, help="SQLAlchemy URL (default MGRAO_DATABASE_URL).")
def migrate(database_url: str | None) -> None:
    """Create or upgrade the database schema, then exit (a deployment's one-shot step)."""
    from backend.settings import Settings
    from backend.store.db import Database

    settings = Settings(database_url=database_url) if database_url else Settings()
    db = Database(settings.database_url, settings.db_busy_timeout_s)
    try:
        db.migrate()
    finally:
        db.dispose()
    click.echo(f"mgrao: {settings.database_url} is at the newest schema", err=True)
