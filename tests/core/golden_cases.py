"""The runs whose every bit is kept in ``tests/fixtures/golden_runs.npz`` (see test_golden.py).

Every paper system with its algorithms and the oracle, and every reading of the environment and
of the learner that changes which floating-point operations run: quality models, load sharing,
per-task routing, tie breaks, rejoining profiles, counted absent tasks, the paper-literal
temperature, and children with more than ``MIN_BOUNDED_GROUPS`` groups (the bounded lazy update); the
standard learners and adaptive groups, and several resources (each added with the numbers of the code before it
changed: the cost of learning's, issue 33).

Regenerate the fixture only for an intended change of numbers:
``python -m tests.core.golden_cases`` (and say why in the commit).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

FIXTURE = Path(__file__).resolve().parent.parent / "fixtures" / "golden_runs.npz"

CASES: dict[str, dict] = {
    "single": {"system": "single", "algorithms": ["uniform", "oracle", "mgrao-1:1", "mgrao-2:1", "mgrao-max"]},
    "multi": {"system": "multi", "algorithms": ["uniform", "oracle", "mgrao-1:1", "mgrao-5:1", "mgrao-max"]},
    "volatile": {"system": "volatile", "algorithms": ["uniform", "oracle", "mgrao-1:1", "mgrao-max"]},
    "large": {"system": "large", "algorithms": ["uniform", "oracle", "mgrao-1:1", "mgrao-5:1", "mgrao-25:1",
                                                "mgrao-max"]},
    "exponential": {"system": "single", "overrides": {"quality_model": "exponential"}},
    "relative-linear": {"system": "multi", "overrides": {"quality_model": "relative-linear"},
                        "algorithms": ["uniform", "oracle", "mgrao-1:1", "mgrao-max"]},
    "load-sharing": {"system": "multi", "overrides": {"load_sharing": True},
                     "algorithms": ["uniform", "oracle", "mgrao-2:1", "mgrao-max"]},
    "per-task": {"system": "multi", "overrides": {"routing": "per-task", "tie_break": "first"}},
    "rejoin-new-counted": {"system": "volatile", "overrides": {"rejoin_profile": "new", "absent_tasks": "counted"},
                           "algorithms": ["uniform", "oracle", "mgrao-1:1", "mgrao-max"]},
    "paper-temperature": {"system": "single", "overrides": {"temperature": 1.0, "learning_rate": 0.3,
                                                            "trace_decay": 0.5}},
    "bounded": {"system": "single", "overrides": {"n_parents": 150, "types_per_composite": 3},
                "algorithms": ["uniform", "mgrao-75:1", "mgrao-max"], "episodes": 30},
    "bounded-multi": {"system": "multi", "overrides": {"n_parents": 90, "routing": "per-task"},
                      "algorithms": ["uniform", "mgrao-90:1"], "episodes": 25},
    "learners": {"system": "multi", "algorithms": ["uniform", "mgrao-adaptive:2", "independent-q", "bandit"],
                 "beside": ["mgrao-1:1"]},
    "multi-resource": {"system": "multi-resource", "algorithms": ["uniform", "oracle", "mgrao-1:1", "mgrao-max",
                                                                 "mgrao-adaptive:2", "independent-q", "bandit"]},
    "resources-several-children": {
        "system": "multi", "overrides": {"n_resources": 2, "resource_combination": "weighted",
                                         "resource_credit": "by-share"},
        "algorithms": ["uniform", "mgrao-2:1", "independent-q", "bandit"], "beside": ["mgrao-adaptive:2"]},
}
"""``beside``: configurations run beside a case's and not kept. They make the case's kernel signature (the learner
families a chunk holds, :mod:`mgrao_core.engine.kernel`) one that other tests compile anyway, which saves the suite a
compile of the kernel; a lane's numbers do not depend on the lanes beside it (``tests/core/test_determinism.py``)."""
SEEDS = (0, 7, 123)
EPISODES = 40


def compute(name: str) -> dict[str, np.ndarray]:
    """The runs of case ``name``: ``{"<case>|<algorithm>|<seed>|<what>": array}``."""
    from mgrao_core import make_spec, run_experiment

    case = CASES[name]
    beside = case.get("beside", [])
    algorithms = case.get("algorithms")
    spec = make_spec(case["system"], algorithms and [*algorithms, *beside], list(SEEDS),
                     case.get("episodes", EPISODES), case.get("overrides"))
    out = {}
    for run in run_experiment(spec).runs:
        if run.algorithm in beside:
            continue
        key = f"{name}|{run.algorithm}|{run.seed}"
        out[f"{key}|utilities"] = run.utilities
        out[f"{key}|group_weights"] = run.group_weights
        out[f"{key}|combined_weights"] = run.combined_weights
    return out


def main() -> None:
    arrays = {}
    for name in CASES:
        arrays |= compute(name)
    np.savez_compressed(FIXTURE, **arrays)
    print(f"{len(arrays)} arrays written to {FIXTURE}")


if __name__ == "__main__":
    main()
