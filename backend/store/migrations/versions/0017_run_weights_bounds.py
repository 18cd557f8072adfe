"""A run stores its final weights within stated bounds, says what it kept, and their mean over its children.

``runs.weights_meta`` (JSON): ``{"children", "combined_children", "group_children", "means", "group_mean"}``,
the run's children and the first children whose combined and parent-group weights are stored
(:func:`mgrao_core.budget.stored_weights`: 16 MB of each at most, :mod:`backend.store.run_storage`).
``runs.child_means``: for a run of more than 100 children, the weights' mean over every child (combined, then the
PW where kept), little-endian float64. Both null for every run stored before: those kept every weight (no
system had more than 100 children).

Revision ID: 0017
Revises: 0016
Create Date: 2026-12-01
"""

import sqlalchemy as sa
from alembic import op

revision = "0017"
down_revision = "0016"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("runs") as batch:
        batch.add_column(sa.Column("weights_meta", sa.JSON(), nullable=True))
        batch.add_column(sa.Column("child_means", sa.LargeBinary(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("runs") as batch:
        batch.drop_column("child_means")
        batch.drop_column("weights_meta")
