"""Database-specific SQL, all of it in this one module.

SQLite: WAL journal, ``busy_timeout`` and foreign keys on every connection; the driver's own
transaction handling is switched off so that we emit ``BEGIN`` ourselves, and a *write*
transaction starts with ``BEGIN IMMEDIATE`` (it takes the write lock at once, so a transaction
that reads and then writes never fails half-way with SQLITE_BUSY). PostgreSQL: the queue's
claim uses ``SELECT ... FOR UPDATE SKIP LOCKED`` instead. Both: the database's clock, and an
insert that skips rows already present.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import timedelta
from typing import Any

from sqlalchemy import ColumnElement, Engine, Select, event, func
from sqlalchemy.dialects.postgresql import insert as postgresql_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session

WRITE_OPTION = "mgrao_write"
BUSY_TIMEOUT_MS = 30_000


def is_sqlite(url_or_engine: Any) -> bool:
    """Whether a URL string or an engine is SQLite."""
    if isinstance(url_or_engine, Engine):
        return url_or_engine.dialect.name == "sqlite"
    return str(url_or_engine).startswith("sqlite")


def connect_args(url: str) -> dict[str, Any]:
    """Extra DBAPI connect arguments for ``create_engine``."""
    if is_sqlite(url):
        return {"check_same_thread": False, "timeout": BUSY_TIMEOUT_MS / 1000}
    return {}


def configure_engine(engine: Engine) -> None:
    """Install the per-connection setup (SQLite only; a no-op elsewhere)."""
    if not is_sqlite(engine):
        return

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, _record: Any) -> None:
        dbapi_connection.isolation_level = None  # we emit BEGIN ourselves (see _on_begin)
        cursor = dbapi_connection.cursor()
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute(f"PRAGMA busy_timeout={BUSY_TIMEOUT_MS}")
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
