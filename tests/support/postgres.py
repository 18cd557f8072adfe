"""A throwaway PostgreSQL server for the tests and benchmarks: started, used and stopped by them.

It runs Debian's PostgreSQL binaries (``/usr/lib/postgresql/<version>/bin``, or ``initdb`` on the
PATH) from a temporary directory, as an unprivileged user when we are root (the server refuses to
run as root), listening on a free port on 127.0.0.1 only, with durability off (a test server).
Each test gets a database of its own. :func:`binaries` is None where no server can be had, and
the tests that need one skip, saying so.
"""

from __future__ import annotations

import os
import pwd
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tests.support.local_service import free_port

UNPRIVILEGED = "nobody"


def binaries() -> Path | None:
    """The directory of ``initdb``, ``pg_ctl`` and ``postgres``, newest version first; None if absent."""
    candidates = sorted(Path("/usr/lib/postgresql").glob("*/bin"), key=lambda p: int(p.parent.name),
                        reverse=True) if Path("/usr/lib/postgresql").is_dir() else []
    on_path = shutil.which("initdb")
    if on_path:
        candidates.append(Path(on_path).parent)
    for directory in candidates:
        if all((directory / name).exists() for name in ("initdb", "pg_ctl", "postgres")):
            return directory
    return None


def why_unavailable() -> str | None:
    """Why no server can be started here, or None when one can."""
    if binaries() is None:
        return "PostgreSQL's server binaries are not installed (Debian: apt-get install postgresql)"
    if os.geteuid() == 0:
        try:
            pwd.getpwnam(UNPRIVILEGED)
        except KeyError:
            return f"running as root and there is no unprivileged user {UNPRIVILEGED!r} to run PostgreSQL as"
    return None


class PostgresServer:
    """One PostgreSQL server in a temporary directory; :meth:`stop` ends it by its process id."""

    def __init__(self) -> None:
        self.bin = binaries()
        if self.bin is None:
            raise RuntimeError(why_unavailable())
        self.root = Path(tempfile.mkdtemp(prefix="mgrao-pg-"))
        self.data = self.root / "data"
        self.port = free_port()
        self.user = "mgrao"
        self.pid: int | None = None
        self._databases = 0
        self._as_user = None
        if os.geteuid() == 0:
            entry = pwd.getpwnam(UNPRIVILEGED)
            os.chown(self.root, entry.pw_uid, entry.pw_gid)
            self._as_user = entry

    def _run(self, *argv: str, timeout: float = 120) -> subprocess.CompletedProcess:
        entry = self._as_user

        def demote() -> None:
            if entry is not None:
                os.setgid(entry.pw_gid)
                os.setuid(entry.pw_uid)

        env = {"PATH": f"{self.bin}:/usr/bin:/bin", "LC_ALL": "C.UTF-8", "HOME": str(self.root)}
        done = subprocess.run(argv, preexec_fn=demote, env=env, capture_output=True, text=True, timeout=timeout,
                              check=False)
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(argv)} failed: {done.stdout}\n{done.stderr}")
        return done

    def start(self) -> PostgresServer:
        """initdb, then start the server and wait until it accepts connections."""
        self._run(str(self.bin / "initdb"), "-D", str(self.data), "-U", self.user, "-A", "trust", "-E", "UTF8",
                  "--no-sync")
        self._start_server()
        return self

    def _start_server(self) -> None:
        options = (f"-p {self.port} -c listen_addresses=127.0.0.1 -k {self.root} -c fsync=off "
                   "-c synchronous_commit=off -c full_page_writes=off -c max_connections=300 "
                   "-c shared_buffers=64MB")
        self._run(str(self.bin / "pg_ctl"), "-D", str(self.data), "-o", options, "-l", str(self.root / "server.log"),
                  "-w", "-t", "60", "start")
        self.pid = int((self.data / "postmaster.pid").read_text().splitlines()[0])

    def halt(self) -> None:
        """An outage: stop the server at once (``pg_ctl stop -m immediate``), keeping its data for :meth:`resume`."""
        self._run(str(self.bin / "pg_ctl"), "-D", str(self.data), "-m", "immediate", "-w", "-t", "60", "stop")
        self.pid = None

    def resume(self) -> None:
        """Start the server again on the same port and data after :meth:`halt`."""
        self._start_server()

    def url(self, database: str = "postgres") -> str:
        """The SQLAlchemy URL of ``database`` (psycopg 3)."""
        return f"postgresql+psycopg://{self.user}@127.0.0.1:{self.port}/{database}"

    def create_database(self, template: str | None = None) -> str:
        """A new database, empty or a copy of the one at URL ``template`` (nobody may be connected to it); its URL."""
        import psycopg

        self._databases += 1
        name = f"test_{os.getpid()}_{self._databases}"
        copy = f' TEMPLATE "{template.rsplit("/", 1)[1]}"' if template else ""
        with psycopg.connect(f"host=127.0.0.1 port={self.port} user={self.user} dbname=postgres",
                             autocommit=True) as connection:
            connection.execute(f'CREATE DATABASE "{name}"{copy}')
        return self.url(name)

    def drop_database(self, url: str) -> None:
        """Drop a database made by :meth:`create_database`, ending its sessions first."""
        import psycopg

        name = url.rsplit("/", 1)[1]
        with psycopg.connect(f"host=127.0.0.1 port={self.port} user={self.user} dbname=postgres",
                             autocommit=True) as connection:
            connection.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')

    def stop(self) -> None:
        """Stop the server (SIGINT to its postmaster: a fast shutdown), then remove its directory."""
        if self.pid is not None:
            try:
                os.kill(self.pid, signal.SIGINT)
                deadline = time.monotonic() + 30
                while time.monotonic() < deadline and _running(self.pid):
                    time.sleep(0.05)
                if _running(self.pid):
                    os.kill(self.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.pid = None
        shutil.rmtree(self.root, ignore_errors=True)


def _running(pid: int) -> bool:
    """``pid`` exists and has not exited. The postmaster is not our child (``pg_ctl`` started it): once it has
    exited it stays a zombie until process 1 reaps it, which took 2 s and more here, and a zombie still answers
    ``kill(pid, 0)``."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    except (OSError, IndexError):  # no /proc: ask the kernel, zombies counted as running
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        return True
    return state not in ("Z", "X")


@contextmanager
def throwaway_server() -> Iterator[PostgresServer]:
    """A started server for a test or a session, stopped on leaving; a skip saying why where none can start."""
    import pytest

    reason = why_unavailable()
    if reason is not None:
        pytest.skip(reason)
    server = PostgresServer().start()
    try:
        yield server
    finally:
        server.stop()
