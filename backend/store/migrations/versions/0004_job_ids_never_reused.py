"""A deleted job's id is never given to a new job (SQLite: AUTOINCREMENT).

SQLite gives a new row the largest id plus one, so deleting the newest job made its id the next
one's: a stale link, bookmark or retried DELETE then reached another job. PostgreSQL's sequences
never reuse ids. The table is rebuilt with AUTOINCREMENT; the rebuild runs with foreign-key
enforcement off (see ``backend.store.db.upgrade``), so that dropping the old table does not cascade to
the runs and tags, which keep pointing at ``jobs`` by name.

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-21
"""

from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def _rebuild(autoincrement: bool) -> None:
    if op.get_bind().dialect.name != "sqlite":
        return
    with op.batch_alter_table("jobs", recreate="always", table_kwargs={"sqlite_autoincrement": autoincrement}):
        pass
    problems = op.get_bind().exec_driver_sql("PRAGMA foreign_key_check").fetchall()
    if problems:
        raise RuntimeError(f"rebuilding jobs broke foreign keys: {problems[:5]}")


def upgrade() -> None:
    _rebuild(True)


def downgrade() -> None:
    _rebuild(False)
