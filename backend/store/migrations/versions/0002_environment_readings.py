"""Stored jobs keep the environment they ran in: write the first reading into their configuration.

Before this revision the simulated environment had one reading: relative-linear quality, parents
choosing a child per atomic task, absent parents excluded. The new defaults differ (hyperbolic
quality, per-composite routing), so a stored configuration without these parameters would now
mean something else. This data migration writes the old reading into every job's ``config``
and recomputes its ``config_hash``, so that old jobs re-run bit-identically and never pool with
jobs of the new default in comparisons. The values and the hash function are frozen here, as
they were at this revision. Configurations that already name a quality model are left alone.
Stored values that the revision's tighter bounds refuse (e.g. a temperature below 1e-4) are kept
as they are: such a job re-runs only after its configuration is corrected, and says why.

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-21
"""

import hashlib
import json

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None

FIRST_READING = {
    "quality_model": "relative-linear",
    "half_saturation": 0.2,
    "load_sharing": False,
    "routing": "per-task",
    "absent_tasks": "excluded",
    "absent_quality": None,
}

jobs = sa.table("jobs", sa.column("id", sa.Integer), sa.column("config", sa.JSON), sa.column("config_hash", sa.String))


def _hash(config: dict) -> str:
    core = {k: v for k, v in config.items() if k not in ("seeds", "algorithms")}
    return hashlib.sha256(json.dumps(core, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()).hexdigest()


def _rewrite(change) -> None:
    connection = op.get_bind()
    for job_id, config in connection.execute(sa.select(jobs.c.id, jobs.c.config)).all():
        params = change(dict(config["params"]))
        if params is None:
            continue
        updated = dict(config, params=params)
        connection.execute(jobs.update().where(jobs.c.id == job_id).values(config=updated, config_hash=_hash(updated)))


def upgrade() -> None:
    _rewrite(lambda params: None if "quality_model" in params else params | FIRST_READING)


def downgrade() -> None:
    # Only configurations in the first reading can be expressed without these parameters
    # (half_saturation does not matter to relative-linear quality). Jobs of another reading keep
    # them: revision 0001's code refuses to re-run them, naming the unknown parameter.
    def strip(params: dict) -> dict | None:
        if any(params.get(k, v) != v for k, v in FIRST_READING.items() if k != "half_saturation"):
            return None
        return {k: v for k, v in params.items() if k not in FIRST_READING}

    _rewrite(strip)
