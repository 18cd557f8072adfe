"""Studies and their trials; a job may belong to a study's trial.

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-21
"""

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None

ID = sa.BigInteger().with_variant(sa.Integer(), "sqlite")


def upgrade() -> None:
    op.create_table(
        "studies",
        sa.Column("id", ID, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("method", sa.String(16), nullable=False),
        sa.Column("definition", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("planned", sa.Integer(), nullable=False),
        sa.Column("best_trial", sa.Integer(), nullable=True),
        sa.Column("best_value", sa.Float(), nullable=True),
        sa.Column("revision", sa.Integer(), nullable=False),
        sa.Column("version", sa.String(32), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("finished_at", sa.DateTime(), nullable=True),
        sqlite_autoincrement=True,
    )
    op.create_index("ix_studies_created", "studies", ["created_at", "id"])
    op.create_index("ix_studies_status", "studies", ["status"])
    op.create_table(
        "trials",
        sa.Column("id", ID, primary_key=True),
        sa.Column("study_id", ID, sa.ForeignKey("studies.id", ondelete="CASCADE"), nullable=False),
        sa.Column("number", sa.Integer(), nullable=False),
        sa.Column("params", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("value", sa.Float(), nullable=True),
        sa.Column("low", sa.Float(), nullable=True),
        sa.Column("high", sa.Float(), nullable=True),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("runs", sa.Integer(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("finished_at", sa.DateTime(), nullable=True),
        sa.UniqueConstraint("study_id", "number", name="uq_trials_study_number"),
    )
    op.create_index("ix_trials_study_status", "trials", ["study_id", "status"])
    # SQLite rebuilds the table for the foreign keys: it must keep AUTOINCREMENT (migration 0004)
    with op.batch_alter_table("jobs", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.add_column(sa.Column("study_id", ID, nullable=True))
        batch.add_column(sa.Column("trial_id", ID, nullable=True))
        batch.create_foreign_key("fk_jobs_study", "studies", ["study_id"], ["id"], ondelete="CASCADE")
        batch.create_foreign_key("fk_jobs_trial", "trials", ["trial_id"], ["id"], ondelete="SET NULL")
        batch.create_index("ix_jobs_study_id", ["study_id"])
        batch.create_index("ix_jobs_trial_id", ["trial_id"])


def downgrade() -> None:
    with op.batch_alter_table("jobs", table_kwargs={"sqlite_autoincrement": True}) as batch:
        batch.drop_index("ix_jobs_trial_id")
        batch.drop_index("ix_jobs_study_id")
        batch.drop_constraint("fk_jobs_trial", type_="foreignkey")
        batch.drop_constraint("fk_jobs_study", type_="foreignkey")
        batch.drop_column("trial_id")
        batch.drop_column("study_id")
    op.drop_table("trials")
    op.drop_table("studies")
