"""Job and run ids are 64-bit on every database (SQLite's INTEGER already is; PostgreSQL's was 32-bit).

The API accepts ids in [1, 2^63-1]; on PostgreSQL a 32-bit ``jobs.id`` made the largest well-formed
id an error ("integer out of range") instead of a plain 404, and would end the ids at 2^31-1.

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-21
"""

from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None

COLUMNS = (("jobs", "id", "jobs_id_seq"), ("job_tags", "job_id", None), ("runs", "id", "runs_id_seq"),
           ("runs", "job_id", None))


def _retype(sql_type: str) -> None:
    if op.get_bind().dialect.name != "postgresql":
        return  # SQLite's INTEGER PRIMARY KEY is 64-bit already
    for table, column, sequence in COLUMNS:
        op.execute(f"ALTER TABLE {table} ALTER COLUMN {column} TYPE {sql_type}")
        if sequence:
            op.execute(f"ALTER SEQUENCE {sequence} AS {sql_type}")


def upgrade() -> None:
    _retype("BIGINT")


def downgrade() -> None:
    _retype("INTEGER")
