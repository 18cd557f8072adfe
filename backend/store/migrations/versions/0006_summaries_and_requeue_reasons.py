"""Per-configuration summaries of finished jobs (for the runs table's result columns) and the reason a
job was last re-queued.

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-21
"""

import sqlalchemy as sa
from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None

ID = sa.BigInteger().with_variant(sa.Integer(), "sqlite")


def upgrade() -> None:
    op.create_table(
        "job_summaries",
        sa.Column("job_id", ID, sa.ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True),
        sa.Column("algorithm", sa.String(32), primary_key=True),
        sa.Column("n_runs", sa.Integer(), nullable=False),
        sa.Column("final_mean", sa.Float(), nullable=True),
        sa.Column("final_low", sa.Float(), nullable=True),
        sa.Column("final_high", sa.Float(), nullable=True),
        sa.Column("pct_from_uniform", sa.Float(), nullable=True),
        sa.Column("pct_low", sa.Float(), nullable=True),
        sa.Column("pct_high", sa.Float(), nullable=True),
        sa.Column("pct_of_max", sa.Float(), nullable=True),
    )
    op.create_index("ix_job_summaries_final", "job_summaries", ["algorithm", "final_mean", "job_id"])
    op.create_index("ix_job_summaries_pct", "job_summaries", ["algorithm", "pct_from_uniform", "job_id"])
    with op.batch_alter_table("jobs", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.add_column(sa.Column("requeue_reason", sa.Text(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("jobs", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.drop_column("requeue_reason")
    op.drop_table("job_summaries")
