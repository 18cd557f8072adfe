"""Database-specific SQL, all of it in this one module.

SQLite: WAL journal, ``busy_timeout`` and foreign keys on every connection; the driver's own
transaction handling is switched off so that we emit ``BEGIN`` ourselves, and a *write*
transaction starts with ``BEGIN IMMEDIATE`` (it takes the write lock at once, so a transaction
that reads and then writes never fails half-way with SQLITE_BUSY). PostgreSQL: the queue's
claim uses ``SELECT ... FOR UPDATE SKIP LOCKED`` instead.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import Engine, Select, event
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


def lock_for_claim(session: Session, statement: Select) -> Select:
    """Prepare the queue's claim: lock the database (SQLite) or skip locked rows (PostgreSQL)."""
    if session.get_bind().dialect.name == "sqlite":
        begin_write(session)
        return statement
    return statement.with_for_update(skip_locked=True)
