"""A stored summary says how many seeds its paired figures stand on (``n_paired``, ``n_paired_max``).

``n_paired``: the seeds of the configuration that uniform also ran with a positive final utility, on which
its % from uniform is computed; ``n_paired_max``: those that ``mgrao-max`` also ran, on which its % of max
is (``mgrao_core.summarise``, docs/statistics.md). This migration adds both and computes them for every
stored summary from its job's runs, one job at a time, with the same core function.

Revision ID: 0013
Revises: 0012
Create Date: 2026-11-26
"""

import numpy as np
import sqlalchemy as sa
from alembic import op

from mgrao_core import final_utilities, summarise

revision = "0013"
down_revision = "0012"
branch_labels = None
depends_on = None

runs = sa.table("runs", sa.column("job_id", sa.Integer), sa.column("algorithm", sa.String),
                sa.column("seed", sa.Integer), sa.column("utilities", sa.LargeBinary))
summaries = sa.table("job_summaries", sa.column("job_id", sa.Integer), sa.column("algorithm", sa.String),
                     sa.column("n_paired", sa.Integer), sa.column("n_paired_max", sa.Integer))


def upgrade() -> None:
    with op.batch_alter_table("job_summaries") as batch:
        batch.add_column(sa.Column("n_paired", sa.Integer(), nullable=True))
        batch.add_column(sa.Column("n_paired_max", sa.Integer(), nullable=True))
    connection = op.get_bind()
    jobs = connection.execute(sa.select(summaries.c.job_id).distinct().order_by(summaries.c.job_id)).scalars().all()
    for job_id in jobs:
        finals: dict[str, dict[int, float]] = {}
        for algorithm, seed, blob in connection.execute(  # streamed, a few runs at a time
            sa.select(runs.c.algorithm, runs.c.seed, runs.c.utilities).where(runs.c.job_id == job_id)
            .execution_options(yield_per=16)
        ):
            finals.setdefault(algorithm, {})[seed] = float(final_utilities(np.frombuffer(blob, dtype="<f8"))[0])
        for algorithm, s in summarise(finals).items():
            connection.execute(summaries.update()
                               .where(summaries.c.job_id == job_id, summaries.c.algorithm == algorithm)
                               .values(n_paired=s.n_paired, n_paired_max=s.n_paired_max))


def downgrade() -> None:
    with op.batch_alter_table("job_summaries") as batch:
        batch.drop_column("n_paired_max")
        batch.drop_column("n_paired")
