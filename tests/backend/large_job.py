"""A job of 10,000 children (issue 42, item 4), as the service tests run it on a local worker and on Dask."""

from __future__ import annotations

from functools import cache

import numpy as np
from sqlalchemy import select

from backend.store.db import Database
from backend.store.models import Run
from mgrao_core import ExperimentResult, make_spec, run_experiment
from mgrao_core.budget import MAX_STORED_GROUP_VALUES

CHILDREN, GROUPS, TYPES = 10_000, 100, 20
PARAMS = {"n_children": CHILDREN, "n_parents": 20_000, "topology": "ring", "children_per_parent": 4}
ALGORITHMS = ["uniform", "mgrao-100:1"]
SEEDS = [3, 1]
EPISODES = 3
KEPT_GROUP_CHILDREN = MAX_STORED_GROUP_VALUES // (GROUPS * TYPES)  # 1,000: the first children whose PW are stored


@cache
def expected() -> ExperimentResult:
    """The same job in one process: what the service's runs must equal."""
    return run_experiment(make_spec("multi", ALGORITHMS, SEEDS, EPISODES, PARAMS))


def core_run(algorithm: str, seed: int):
    return next(r for r in expected().runs if r.algorithm == algorithm and r.seed == seed)


def assert_stored_within_bounds(db: Database, job_id: int) -> None:
    """Every run of a large job as stored: its combined weights whole, the first 1,000 children's PW, the means."""
    with db.session() as session:
        runs = session.scalars(select(Run).where(Run.job_id == job_id)).all()
    assert {(r.algorithm, r.seed) for r in runs} == {(a, s) for a in ALGORITHMS for s in SEEDS}
    for run in runs:
        want = core_run(run.algorithm, run.seed)
        assert run.utilities == want.utilities.astype("<f8").tobytes()
        assert run.combined_weights == want.combined_weights.tobytes()  # 1.6 MB: every child's
        assert run.group_shape == [CHILDREN, want.group_weights.shape[1], TYPES]
        means = np.frombuffer(run.child_means, dtype="<f8")
        assert np.array_equal(means[:TYPES], want.combined_weights.mean(axis=0))
        if run.algorithm == "uniform":
            assert run.group_weights == b"" and len(means) == TYPES
            assert run.weights_meta == {"children": CHILDREN, "combined_children": CHILDREN,
                                        "group_children": CHILDREN, "means": True, "group_mean": False}
            continue
        # 10,000 children x 100 groups x 20 types would be 160 MB: the first 1,000 children's, 16 MB
        assert len(run.group_weights) == 8 * MAX_STORED_GROUP_VALUES
        assert run.group_weights == want.group_weights[:KEPT_GROUP_CHILDREN].tobytes()
        assert np.array_equal(means[TYPES:].reshape(GROUPS, TYPES), want.group_weights.mean(axis=0))
        assert run.weights_meta == {"children": CHILDREN, "combined_children": CHILDREN,
                                    "group_children": KEPT_GROUP_CHILDREN, "means": True, "group_mean": True}
