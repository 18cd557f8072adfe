"""Every stored summary recomputed from its job's runs: one interval per experiment, whatever its age.

A job's summaries (``job_summaries``) are computed once, when it succeeds. Jobs stored while the 95% t
intervals took Student's quantile from a table (three decimals to 30 degrees of freedom, a Cornish-Fisher
expansion beyond; until commit 8a852eb) kept those intervals, while their results, computed on read, and any
new identical job use the exact quantile (``mgrao_core.statistics.student.t_quantile``): job 1 showed [0.41193201,
1.18388720] in its record and [0.41187013, 1.18394909] in its results. Rows stored since carry the quantile of
scipy's ``stdtrit`` or the series, within 1e-12 of each other, and their seeds in whatever order the database
gave them (the last bits of a mean depend on it). This data migration recomputes every summary's figures from
its job's runs with today's core (``mgrao_core.summarise``), seeds in the job's order
(``backend.store.summaries.in_seed_order``), as a job finishing now stores them and as its results compute them;
the task counts stay. It reads each job's runs in turn, a few at a time, never the whole table at once, and
names the columns it writes itself (``FIGURES``), as a migration stands on its revision's schema.

Downgrading keeps the recomputed figures (the schema does not change; the old ones were the inexact ones).

Revision ID: 0016
Revises: 0015
Create Date: 2026-11-28
"""

import math

import numpy as np
import sqlalchemy as sa
from alembic import op

from backend.store.summaries import in_seed_order
from mgrao_core import final_utilities, summarise

revision = "0016"
down_revision = "0015"
branch_labels = None
depends_on = None

jobs = sa.table("jobs", sa.column("id", sa.Integer), sa.column("config", sa.JSON))
runs = sa.table("runs", sa.column("id", sa.Integer), sa.column("job_id", sa.Integer),
                sa.column("algorithm", sa.String), sa.column("seed", sa.Integer),
                sa.column("utilities", sa.LargeBinary))
FIGURES = ("n_runs", "final_mean", "final_low", "final_high", "pct_from_uniform", "pct_low", "pct_high", "pct_of_max",
           "n_paired", "n_paired_max")
summaries = sa.table("job_summaries", sa.column("job_id", sa.Integer), sa.column("algorithm", sa.String),
                     *(sa.column(name) for name in FIGURES))


def _finite(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None


def upgrade() -> None:
    connection = op.get_bind()
    stored = connection.execute(sa.select(summaries.c.job_id).distinct().order_by(summaries.c.job_id)).scalars().all()
    for job_id in stored:
        config = connection.execute(sa.select(jobs.c.config).where(jobs.c.id == job_id)).scalar()
        finals: dict[str, dict[int, float]] = {}
        for algorithm, seed, blob in connection.execute(  # streamed, a few runs at a time, in the order stored
            sa.select(runs.c.algorithm, runs.c.seed, runs.c.utilities).where(runs.c.job_id == job_id)
            .order_by(runs.c.id).execution_options(yield_per=16)
        ):
            finals.setdefault(algorithm, {})[seed] = float(final_utilities(np.frombuffer(blob, dtype="<f8"))[0])
        for algorithm, s in summarise(in_seed_order(finals, (config or {}).get("seeds", []))).items():
            pct_low, pct_high = s.pct_ci95 if s.pct_ci95 is not None else (None, None)
            connection.execute(summaries.update()
                               .where(summaries.c.job_id == job_id, summaries.c.algorithm == algorithm)
                               .values(n_runs=s.n_runs, final_mean=_finite(s.final_mean),
                                       final_low=_finite(s.ci95[0]), final_high=_finite(s.ci95[1]),
                                       pct_from_uniform=_finite(s.pct_from_uniform), pct_low=_finite(pct_low),
                                       pct_high=_finite(pct_high), pct_of_max=_finite(s.pct_of_max),
                                       n_paired=s.n_paired, n_paired_max=s.n_paired_max))


def downgrade() -> None:
    pass
