"""The compiled simulation engine (numba): the environment and the batched kernel.

* :mod:`~mgrao_core.engine.environment`: what parents and children do with tasks (absent parents,
  proportional values, choosing a child, quality of an atomic task, estimates of children);
* :mod:`~mgrao_core.engine.kernel`: the lanes, the world and the draws as the kernel reads them,
  and the loop over episodes that strings the paper's five processing steps together, calling each
  learner family's compiled steps (MG-RAO's: :mod:`mgrao_core.algorithms.mgrao.compiled`);
* :mod:`~mgrao_core.engine.observation`: what a child sees of an episode (the environments').

Everything here is checked against the dense reference (:mod:`mgrao_core.reference`).
"""

import mgrao_core._numba_cache  # noqa: F401, I001  (first: picks a writable numba cache before numba loads)
from mgrao_core.engine.cache import argument_types, bind_to_sources, has_code, load_without_compiler
from mgrao_core.engine.environment import Environment, environment_of
from mgrao_core.engine.kernel import Draws, Failing, Lanes, Outside, SeveralResources, Worlds, finish, run_block
from mgrao_core.engine.observation import child_observations

bind_to_sources([run_block, finish, child_observations])
load_without_compiler([run_block, finish, child_observations])

__all__ = [
    "argument_types",
    "child_observations",
    "Draws",
    "Environment",
    "Failing",
    "Lanes",
    "Outside",
    "SeveralResources",
    "Worlds",
    "environment_of",
    "finish",
    "has_code",
    "run_block",
]
