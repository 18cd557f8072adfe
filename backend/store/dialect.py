"""Database-specific SQL, all of it in this one module.

SQLite: WAL journal, ``busy_timeout`` and foreign keys on every connection; the driver's own
transaction handling is switched off so that we emit ``BEGIN`` ourselves, and a *write*
transaction starts with ``BEGIN IMMEDIATE`` (it takes the write lock at once, so a transaction
that reads and then writes never fails half-way with SQLITE_BUSY). PostgreSQL: the queue's
claim uses ``SELECT ... FOR UPDATE SKIP LOCKED`` instead. Both: the database's clock, and an
insert that skips rows already present.
"""

from __future__ import annotations

import os
import sqlite3
from collections.abc import Sequence
from datetime import timedelta
from pathlib import Path
from typing import Any
from urllib.parse import quote

from sqlalchemy import ColumnElement, Engine, Select, create_engine, event, func, make_url
from sqlalchemy.dialects.postgresql import insert as postgresql_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.orm import Session
from sqlalchemy.pool import NullPool

WRITE_OPTION = "mgrao_write"
BUSY_TIMEOUT_MS = 30_000


def is_sqlite(url_or_engine: Any) -> bool:
    """Whether a URL string or an engine is SQLite."""
    if isinstance(url_or_engine, Engine):
        return url_or_engine.dialect.name == "sqlite"
    return str(url_or_engine).startswith("sqlite")


def sqlite_file(url: str) -> Path | None:
    """The database file of a SQLite URL (None for other databases and in-memory SQLite)."""
    parsed = make_url(url)
    if parsed.get_backend_name() != "sqlite" or parsed.database in (None, "", ":memory:"):
        return None
    return Path(parsed.database).resolve()


def create_engine_for(url: str, busy_timeout_s: float = BUSY_TIMEOUT_MS / 1000) -> Engine:
    """The engine of ``url``, set up for this module's conventions (see the module docstring).

    A SQLite file gets a fresh connection per session, opened without the right to create the
    file: a connection that outlives a fault (the file made read-only, moved or deleted) would go
    on writing into a file nobody reads, and a deleted file must not come back empty.
    """
    path = sqlite_file(url)
    if path is None:
        engine = create_engine(url, pool_pre_ping=not is_sqlite(url),
                               connect_args={"check_same_thread": False, "timeout": busy_timeout_s}
                               if is_sqlite(url) else {})
    else:
        def connect() -> sqlite3.Connection:
            return sqlite3.connect(f"file:{quote(str(path))}?mode=rw", uri=True, timeout=busy_timeout_s,
                                   check_same_thread=False)

        engine = create_engine(url, creator=connect, poolclass=NullPool)
    _configure(engine, path, int(busy_timeout_s * 1000))
    return engine


def create_sqlite_file(path: Path) -> None:
    """Create an empty SQLite database file (the engine itself never creates one)."""
    if not path.exists():
        sqlite3.connect(path).close()


def file_identity(path: Path) -> tuple[int, int] | None:
    """``(device, inode)`` of the file now at ``path``, or None if there is none."""
    try:
        stat = os.stat(path)
    except OSError:
        return None
    return stat.st_dev, stat.st_ino


def check_file_identity(session: Session) -> None:
    """Before a commit: the SQLite file at the URL's path is still the one this connection opened.

    Raises:
        DatabaseUnavailable: the file was moved, replaced or deleted meanwhile.
    """
    info = session.connection().connection.info
    path, opened = info.get(_PATH_KEY), info.get(_IDENTITY_KEY)
    if path is not None and file_identity(path) != opened:
        raise DatabaseUnavailable(f"the database file {path} was moved, replaced or deleted; nothing was written")


def probe_write(engine: Engine) -> None:
    """A write transaction that rolls back: proves a fresh connection may write the database.

    Raises:
        DatabaseUnavailable: the reason it cannot (read-only, locked, missing, moved, ...).
    """
    try:
        with engine.connect() as connection:
            connection.execution_options(**{WRITE_OPTION: True})
            transaction = connection.begin()
            try:
                connection.exec_driver_sql("UPDATE alembic_version SET version_num = version_num")
                path, opened = connection.connection.info.get(_PATH_KEY), connection.connection.info.get(_IDENTITY_KEY)
                if path is not None and file_identity(path) != opened:
                    raise DatabaseUnavailable(f"the database file {path} was moved, replaced or deleted")
            finally:
                transaction.rollback()
    except SQLAlchemyError as error:
        raise DatabaseUnavailable(reason(error)) from error


def reason(error: BaseException) -> str:
    """A one-line reason for a database error (the driver's message without SQLAlchemy's noise)."""
    text = str(getattr(error, "orig", None) or error).strip().splitlines()
    return text[0] if text else type(error).__name__


class DatabaseUnavailable(Exception):
    """The database cannot be written or read right now (the service answers 503)."""


def free_bytes(path: Path) -> int:
    """Bytes this process may still write on the file system that holds ``path`` (a file or directory).

    The superuser may also fill the blocks a file system keeps in reserve for it, so for root
    this is the free count, for anyone else the available count.
    """
    info = os.statvfs(path)
    blocks = info.f_bfree if hasattr(os, "geteuid") and os.geteuid() == 0 else info.f_bavail
    return blocks * info.f_frsize


def check_room(path: Path, reserve_bytes: int) -> None:
    """Refuse new work when the SQLite file's file system has less than ``reserve_bytes`` free.

    The database file, its write-ahead log and its journal all live in the file's directory, so
    that is the file system every write needs room on. A completely full disk does not stop a
    write that rolls back (nothing reaches the file), so a write probe alone cannot see it.

    Raises:
        DatabaseUnavailable: naming the free space and the reserve.
    """
    try:
        free = free_bytes(path.parent)
    except OSError:  # the directory itself is gone: the file checks report that
        return
    if free < reserve_bytes:
        raise DatabaseUnavailable(
            f"the disk holding {path} is (nearly) full: {free / 1024**2:.1f} MiB free, less than the "
            f"{reserve_bytes / 1024**2:g} MiB kept for the results of accepted jobs (MGRAO_MIN_FREE_MIB); "
            "no new work is accepted until space is freed")


_PATH_KEY = "mgrao_path"
_IDENTITY_KEY = "mgrao_identity"


def _configure(engine: Engine, path: Path | None, busy_timeout_ms: int) -> None:
    """Install the per-connection setup (SQLite only; a no-op elsewhere)."""
    if not is_sqlite(engine):
        return

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, record: Any) -> None:
        if path is not None:
            record.info[_PATH_KEY] = path
            record.info[_IDENTITY_KEY] = file_identity(path)
        dbapi_connection.isolation_level = None  # we emit BEGIN ourselves (see _on_begin)
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute(f"PRAGMA busy_timeout={busy_timeout_ms}")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(connection: Any) -> None:
        write = connection.get_execution_options().get(WRITE_OPTION, False)
        connection.exec_driver_sql("BEGIN IMMEDIATE" if write else "BEGIN")


def begin_write(session: Session) -> None:
    """Start ``session``'s transaction as a write transaction (``BEGIN IMMEDIATE`` on SQLite).

    Call it first thing in a unit of work that reads and then writes.
    """
    session.connection(execution_options={WRITE_OPTION: True})


MIGRATION_LOCK = 0x6D677261  # "mgra": the advisory lock key of schema migrations on PostgreSQL


def relax_foreign_keys(connection: Any) -> None:
    """SQLite: foreign-key enforcement off on this connection, for schema migrations.

    A migration that rebuilds a table (SQLite cannot alter one in place) drops the old table,
    which with enforcement on would delete every row that refers to it. It must be switched off
    before a transaction begins (SQLite ignores it inside one): here on the driver's connection,
    before SQLAlchemy starts the migration's transaction. Migrations check the keys themselves.
    """
    if connection.dialect.name == "sqlite":
        connection.connection.driver_connection.execute("PRAGMA foreign_keys=OFF")


def lock_for_migration(connection: Any) -> None:
    """Serialise schema migrations between processes that start together.

    PostgreSQL: a transaction-scoped advisory lock; SQLite: the migration's ``BEGIN IMMEDIATE``
    (see :func:`begin_write`) already holds the database.
    """
    if connection.dialect.name == "postgresql":
        connection.exec_driver_sql(f"SELECT pg_advisory_xact_lock({MIGRATION_LOCK})")


def _name(session: Session) -> str:
    return session.get_bind().dialect.name


def skip_locked(session: Session, statement: Select) -> Select:
    """The queue's pick of a job: rows locked by another claim are skipped.

    That is PostgreSQL's ``FOR UPDATE SKIP LOCKED``; SQLite's write transaction already holds the
    whole database.
    """
    if _name(session) == "sqlite":
        return statement
    return statement.with_for_update(skip_locked=True)


def db_now(session: Session, minus_seconds: float | None = None) -> ColumnElement:
    """The database's current UTC time (naive, as the models store it), optionally minus a span.

    SQLite keeps times as text, so the expression yields the text SQLAlchemy writes
    (``YYYY-MM-DD HH:MM:SS.ffffff``) and compares correctly with stored values.
    """
    if _name(session) == "sqlite":
        modifiers = [] if minus_seconds is None else [f"-{float(minus_seconds)!r} seconds"]
        return func.strftime("%Y-%m-%d %H:%M:%f000", "now", *modifiers)
    now = func.timezone("UTC", func.now())
    return now if minus_seconds is None else now - timedelta(seconds=minus_seconds)


def insert_ignoring_duplicates(session: Session, model: type, rows: Sequence[dict[str, Any]]) -> None:
    """Insert ``rows`` into ``model``'s table; a row that collides with a unique key is skipped."""
    if not rows:
        return
    name = _name(session)
    if name == "sqlite":
        statement = sqlite_insert(model).on_conflict_do_nothing()
    elif name == "postgresql":
        statement = postgresql_insert(model).on_conflict_do_nothing()
    else:  # pragma: no cover - the project supports SQLite and PostgreSQL
        raise NotImplementedError(f"no insert-or-ignore for {name}")
    session.execute(statement, list(rows))
