"""Runs logged from outside (docs/platform.md): a job's kind, and the tables an open external run writes.

``jobs.kind`` is ``simulation`` for every job stored so far (the service's workers run them) and
``external`` for a run opened through ``POST /api/external-runs``; ``external_runs`` holds the key it
was opened with, ``external_batches`` the batches it took (by the client's key, so that a retried
batch is not stored twice) and ``external_pieces`` a seed's episodes until they are complete.

Revision ID: 0009
Revises: 0008
Create Date: 2026-11-23
"""

import sqlalchemy as sa
from alembic import op

revision = "0009"
down_revision = "0008"
branch_labels = None
depends_on = None

ID = sa.BigInteger().with_variant(sa.Integer(), "sqlite")


def upgrade() -> None:
    with op.batch_alter_table("jobs", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.add_column(sa.Column("kind", sa.String(16), nullable=False, server_default="simulation"))
    op.create_table(
        "external_runs",
        sa.Column("job_id", ID, sa.ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("open_key", sa.String(64), nullable=True, unique=True),
        sa.Column("definition_digest", sa.String(64), nullable=False),
    )
    op.create_table(
        "external_batches",
        sa.Column("job_id", ID, sa.ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("batch_key", sa.String(64), primary_key=True),
        sa.Column("digest", sa.String(64), nullable=False),
        sa.Column("value_count", sa.Integer(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
    )
    op.create_table(
        "external_pieces",
        sa.Column("job_id", ID, sa.ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("seed", sa.BigInteger(), primary_key=True),
        sa.Column("start", sa.Integer(), primary_key=True),
        sa.Column("count", sa.Integer(), nullable=False),
        sa.Column("utilities", sa.LargeBinary(), nullable=False),
    )


def downgrade() -> None:
    op.drop_table("external_pieces")
    op.drop_table("external_batches")
    op.drop_table("external_runs")
    # no earlier revision can tell an external run from a job: they go, with what refers to them (a
    # migration's SQLite connection does not enforce foreign keys, so no cascade does it)
    external = "SELECT id FROM jobs WHERE kind <> 'simulation'"
    for table in ("runs", "job_tags", "job_summaries"):
        op.execute(f"DELETE FROM {table} WHERE job_id IN ({external})")
    op.execute("DELETE FROM jobs WHERE kind <> 'simulation'")
    with op.batch_alter_table("jobs", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.drop_column("kind")
