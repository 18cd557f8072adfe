"""The compiled simulation engine (numba): the environment and the batched kernel.

* :mod:`~mgrao_core.engine.environment`: what parents and children do with tasks (absent parents,
  proportional values, choosing a child, quality of an atomic task, estimates of children);
* :mod:`~mgrao_core.engine.kernel`: the lanes, the world and the draws as the kernel reads them,
  and the loop over episodes that strings the paper's five processing steps together, calling each
  learner family's compiled steps (MG-RAO's: :mod:`mgrao_core.algorithms.mgrao.compiled`).

Everything here is checked against the dense reference (:mod:`mgrao_core.reference`).
"""

import mgrao_core._numba_cache  # noqa: F401, I001  (first: picks a writable numba cache before numba loads)
from mgrao_core.engine.cache import bind_to_sources, load_without_compiler
from mgrao_core.engine.environment import Environment, environment_of
from mgrao_core.engine.kernel import Draws, Lanes, SeveralResources, Worlds, finish, run_block

bind_to_sources([run_block, finish])
load_without_compiler([run_block, finish])

__all__ = [
    "Draws",
    "Environment",
    "Lanes",
    "SeveralResources",
    "Worlds",
    "environment_of",
    "finish",
    "run_block",
]
