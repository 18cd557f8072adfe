"""Summaries for the jobs that succeeded before summaries were stored.

From this version a job's per-configuration summaries are written in the transaction that marks it
succeeded (``backend/store/summaries.py``). This data migration computes them once for every succeeded
job that has none, from its stored runs, with the same core functions (``mgrao_core.summarise``
over the mean of each run's last episodes), so that the runs table sorts old and new jobs alike.
It reads each job's runs in turn, never the whole table at once.

Revision ID: 0007
Revises: 0006
Create Date: 2026-11-21
"""

import math

import numpy as np
import sqlalchemy as sa
from alembic import op

from mgrao_core import final_utilities, summarise

revision = "0007"
down_revision = "0006"
branch_labels = None
depends_on = None

jobs = sa.table("jobs", sa.column("id", sa.Integer), sa.column("status", sa.String))
runs = sa.table("runs", sa.column("job_id", sa.Integer), sa.column("algorithm", sa.String),
                sa.column("seed", sa.Integer), sa.column("utilities", sa.LargeBinary))
summaries = sa.table(
    "job_summaries", *(sa.column(name) for name in (
        "job_id", "algorithm", "n_runs", "final_mean", "final_low", "final_high", "pct_from_uniform", "pct_low",
        "pct_high", "pct_of_max")),
)


def _finite(value):
    return value if value is not None and math.isfinite(value) else None


def upgrade() -> None:
    connection = op.get_bind()
    done = sa.select(summaries.c.job_id)
    pending = connection.execute(
        sa.select(jobs.c.id).where(jobs.c.status == "succeeded", jobs.c.id.not_in(done)).order_by(jobs.c.id)
    ).scalars().all()
    for job_id in pending:
        finals: dict[str, dict[int, float]] = {}
        for algorithm, seed, blob in connection.execute(
            sa.select(runs.c.algorithm, runs.c.seed, runs.c.utilities).where(runs.c.job_id == job_id)
        ):
            values = np.frombuffer(blob, dtype="<f8")
            finals.setdefault(algorithm, {})[seed] = float(final_utilities(values)[0])
        rows = []
        for algorithm, s in summarise(finals).items():
            pct_low, pct_high = s.pct_ci95 if s.pct_ci95 is not None else (None, None)
            rows.append({
                "job_id": job_id, "algorithm": algorithm, "n_runs": s.n_runs, "final_mean": _finite(s.final_mean),
                "final_low": _finite(s.ci95[0]), "final_high": _finite(s.ci95[1]),
                "pct_from_uniform": _finite(s.pct_from_uniform), "pct_low": _finite(pct_low),
                "pct_high": _finite(pct_high), "pct_of_max": _finite(s.pct_of_max),
            })
        if rows:
            connection.execute(summaries.insert(), rows)


def downgrade() -> None:
    op.execute(summaries.delete())
