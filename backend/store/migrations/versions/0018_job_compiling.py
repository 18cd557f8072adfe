"""A job says while its worker compiles the engine for it, and how long compiling took.

``jobs.compiling`` is the notice of a compile under way for the job (JSON: ``message``, ``parts``,
``estimate_s``, ``since``; ``mgrao_core.compiling.Compiling``), null otherwise; ``jobs.compile_s`` the seconds its
workers spent compiling the engine for it (null: none, or a job stored before this revision). A job's page shows
its time queued, compiling and running apart from them (docs/service.md, "Compiling ahead").

Revision ID: 0018
Revises: 0017
Create Date: 2026-11-28
"""

import sqlalchemy as sa
from alembic import op

revision = "0018"
down_revision = "0017"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("compiling", sa.JSON(), nullable=True))
        batch.add_column(sa.Column("compile_s", sa.Float(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("compile_s")
        batch.drop_column("compiling")
