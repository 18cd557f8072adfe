"""The compiled simulation engine (numba): the environment, MG-RAO's learning and the batched kernel.

* :mod:`~mgrao_core.engine.environment`: what parents and children do with tasks (absent parents,
  proportional values, choosing a child, quality of an atomic task, estimates of children);
* :mod:`~mgrao_core.engine.learning`: algorithm 1 (applied lazily, O(active rows) per value) and
  algorithm 2;
* :mod:`~mgrao_core.engine.kernel`: the lanes, the world and the draws as the kernel reads them,
  and the loop over episodes that strings the paper's five processing steps together.

Everything here is checked against the dense reference (:mod:`mgrao_core.reference`).
"""

import mgrao_core._numba_cache  # noqa: F401, I001  (first: picks a writable numba cache before numba loads)
from mgrao_core.engine.cache import bind_to_sources, load_without_compiler
from mgrao_core.engine.environment import Environment, environment_of
from mgrao_core.engine.kernel import KIND_MGRAO, KIND_ORACLE, KIND_UNIFORM, Draws, Lanes, Worlds, finish, run_block
from mgrao_core.engine.learning import (
    MIN_BOUNDED_GROUPS,
    TRACE_SCALE_LIMIT,
    Learning,
    initial_rows,
    learning_of,
    rebase_interval,
)

bind_to_sources([run_block, finish])
load_without_compiler([run_block, finish])

__all__ = [
    "KIND_MGRAO",
    "KIND_ORACLE",
    "KIND_UNIFORM",
    "MIN_BOUNDED_GROUPS",
    "TRACE_SCALE_LIMIT",
    "Draws",
    "Environment",
    "Lanes",
    "Learning",
    "Worlds",
    "environment_of",
    "finish",
    "initial_rows",
    "learning_of",
    "rebase_interval",
    "run_block",
]
