"""Engine, sessions and schema migrations (Alembic, applied programmatically on start)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from sqlalchemy import Engine
from sqlalchemy.orm import Session, sessionmaker

from backend.store import dialect

if TYPE_CHECKING:
    from alembic.config import Config

PACKAGE_DIR = Path(__file__).resolve().parent


class Database:
    """One engine and its session factory."""

    def __init__(self, url: str, busy_timeout_s: float = dialect.BUSY_TIMEOUT_MS / 1000, *,
                 reserve_bytes: int = 0) -> None:
        self.url = url
        self.file = dialect.sqlite_file(url)
        self.reserve_bytes = reserve_bytes
        self.engine: Engine = dialect.create_engine_for(url, busy_timeout_s)
        self.sessions = sessionmaker(self.engine, expire_on_commit=False)

    @contextmanager
    def session(self) -> Iterator[Session]:
        """A read session (closed afterwards; commit yourself if you write)."""
        with self.sessions() as session:
            yield session

    @contextmanager
    def write(self) -> Iterator[Session]:
        """A write transaction: ``BEGIN IMMEDIATE`` on SQLite, committed on success.

        Raises:
            DatabaseUnavailable: before the commit, when the SQLite file was moved, replaced or
                deleted since the transaction's connection opened it (nothing is committed).
        """
        with self.sessions() as session, session.begin():
            dialect.begin_write(session)
            yield session
            dialect.check_file_identity(session)

    def probe(self) -> None:
        """Check that the database can take new work now: room on its disk, and a write that rolls back.

        Raises:
            DatabaseUnavailable: with the reason.
        """
        if self.file is not None and not self.file.exists():
            raise dialect.DatabaseUnavailable(f"the database file {self.file} is missing (moved or deleted)")
        self.require_room()
        dialect.probe_write(self.engine)

    def require_room(self) -> None:
        """Refuse new work while a SQLite file's disk has less than :attr:`reserve_bytes` free.

        What is kept free is for the results of jobs already accepted. PostgreSQL's disk is its
        server's: there a full disk is reported by the write that fails.

        Raises:
            DatabaseUnavailable: naming the free space and the reserve.
        """
        if self.file is not None and self.reserve_bytes > 0:
            dialect.check_room(self.file, self.reserve_bytes)

    def migrate(self, *, create_missing: bool = True) -> None:
        """Bring the schema to the newest revision, creating a missing SQLite file if asked.

        Only what starts a service (``mgrao serve``, ``mgrao migrate``, the app) creates the file.
        A worker or dispatcher (re)starting while the file is gone must not bring it back empty, or
        the service would accept jobs into a database nobody keeps.

        Raises:
            DatabaseUnavailable: the SQLite file does not exist and ``create_missing`` is False.
        """
        if self.file is not None:
            if create_missing:
                dialect.create_sqlite_file(self.file)
            elif not self.file.exists():
                raise dialect.DatabaseUnavailable(f"the database file {self.file} does not exist "
                                                  "(create it with `mgrao migrate` or `mgrao serve`)")
        upgrade(self.engine)

    def dispose(self) -> None:
        """Close every pooled connection."""
        self.engine.dispose()


def alembic_config() -> Config:
    """The Alembic configuration, located from the installed package's files.

    Alembic is imported here, not with the module: a worker process reads and writes the store but never migrates it,
    and importing Alembic cost each of them about a fifth of a CPU-second (0.78 against 0.59 for backend.processes).
    """
    from alembic.config import Config

    config = Config(str(PACKAGE_DIR / "alembic.ini"))
    config.set_main_option("script_location", str(PACKAGE_DIR / "migrations"))
    return config


def upgrade(engine: Engine) -> None:
    """Apply every pending migration in one write transaction (safe from several processes)."""
    from alembic import command

    config = alembic_config()
    with engine.connect() as connection:
        dialect.relax_foreign_keys(connection)  # before the transaction: table rebuilds must not cascade
        connection.execution_options(**{dialect.WRITE_OPTION: True})
        # Our transaction, begun before Alembic looks: Alembic then runs every step inside it. Left to
        # itself on SQLite (no transactional DDL) it would commit step by step, and two processes
        # starting on a new database could both read the same version and both apply the next step.
        with connection.begin():  # SQLite: BEGIN IMMEDIATE, the database's write lock, held to the end
            dialect.lock_for_migration(connection)
            config.attributes["connection"] = connection
            command.upgrade(config, "head")
