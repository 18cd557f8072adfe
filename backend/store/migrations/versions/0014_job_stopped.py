"""A job run until a question is answered says why it stopped (``jobs.stopped``).

A job whose configuration has a stopping rule (``config.until``, docs/statistics.md "Seeds until decided")
records the rule's verdict after each block of seeds: the last one (``reason`` null while it runs, then
``half_width``, ``decided`` or ``max_seeds``; ``seeds``, ``intervals``, ``outcome``) with ``blocks``, every
block's intervals. Null for every other job and for every job stored before.

Revision ID: 0014
Revises: 0013
Create Date: 2026-11-26
"""

import sqlalchemy as sa
from alembic import op

revision = "0014"
down_revision = "0013"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.add_column(sa.Column("stopped", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("stopped")
