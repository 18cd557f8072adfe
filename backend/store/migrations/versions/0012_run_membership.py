"""Runs of an algorithm whose parent groups change (``mgrao-adaptive:x``) keep their recorded memberships.

``runs.membership`` holds, as little-endian int16, each child's recorded memberships (each parent's
group in each record: ``membership_meta.shape`` is ``[children, records, parents]``, the first record
at episode 0 and one every ``membership_meta.every`` episodes after it); null for every other run and
for every run stored before. Bounded per run (:data:`backend.store.run_storage.MAX_MEMBERSHIP_VALUES`).

Revision ID: 0012
Revises: 0011
Create Date: 2026-11-25
"""

import sqlalchemy as sa
from alembic import op

revision = "0012"
down_revision = "0011"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("runs") as batch:
        batch.add_column(sa.Column("membership", sa.LargeBinary(), nullable=True))
        batch.add_column(sa.Column("membership_meta", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("runs") as batch:
        batch.drop_column("membership_meta")
        batch.drop_column("membership")
