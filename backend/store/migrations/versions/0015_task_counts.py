"""A run keeps what became of its atomic tasks, and a stored summary its configuration's totals.

``runs.tasks_allocated``, ``runs.tasks_failed`` and ``runs.tasks_handed_over`` are the run's
``mgrao_core.TaskCounts`` (docs/model.md, "Tasks that fail, and hierarchical allocation"): the atomic tasks
allocated where a task can fail (``task_need`` > 0), those that failed, and those a neighbouring child
completed (``hierarchy``). ``job_summaries`` holds the same three summed over the configuration's seeds, from
which a summary's ``failure_rate`` and ``handover_rate`` are computed. Every row stored before gets 0: no
task could fail before these counts existed, and a run logged from outside has none.

Revision ID: 0015
Revises: 0014
Create Date: 2026-11-27
"""

import sqlalchemy as sa
from alembic import op

revision = "0015"
down_revision = "0014"
branch_labels = None
depends_on = None

COLUMNS = ("tasks_allocated", "tasks_failed", "tasks_handed_over")
TABLES = ("runs", "job_summaries")


def upgrade() -> None:
    for table in TABLES:
        with op.batch_alter_table(table) as batch:
            for name in COLUMNS:
                batch.add_column(sa.Column(name, sa.BigInteger(), nullable=False, server_default="0"))


def downgrade() -> None:
    for table in TABLES:
        with op.batch_alter_table(table) as batch:
            for name in reversed(COLUMNS):
                batch.drop_column(name)
