"""The template family's compiled steps (:mod:`mgrao_core.algorithms.template`): what the kernel calls.

:func:`lanes_of` builds the family's lanes from the chunk's arrays (the runner calls it).

Each step takes the family's lanes (a flat NamedTuple of arrays and numbers: numba's parallel loop
takes no nested tuple) and the lane's index, and indexes the arrays itself (docs/algorithms.md says
which writes numba's parallel loop would drop as dead once inlined). The kernel calls, for a lane of
the family, with ``m`` the lane's parent groups:

* ``allocate(tl, lane, m, c, weights)`` at the start of every episode, for each child ``c``: write
  the child's allocation into ``weights (n_types,)``;
* ``learn(tl, lane, m, p, n_parents, children, task_types, values)`` when parent ``p``'s composite
  task comes back: atomic task ``k`` of ``task_types[k]`` gave ``values[k]`` to ``children[k]``;
* ``finish(tl, lane, m, weights)`` after the last episode: materialise the final state and write
  every child's final allocation into ``weights (children, n_types)``.
"""

from __future__ import annotations

import mgrao_core._numba_cache  # noqa: F401  (first: picks a writable numba cache before numba loads)

# isort: split
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numba import njit

from mgrao_core.algorithms.state import System


class TemplateLanes(NamedTuple):
    """The family's lanes as its compiled steps read them: its declared arrays, then its parameters."""

    totals: np.ndarray
    template_prior: float


def lanes_of(arrays: Mapping[str, np.ndarray], params: System) -> TemplateLanes:
    """:class:`TemplateLanes` over the chunk's arrays (by name, as declared) and the parameters."""
    return TemplateLanes(arrays["totals"], float(getattr(params, "template_prior", 1.0)))


@njit(cache=True)
def allocate(tl, lane, m, c, weights):
    """Child ``c``'s shares: ``prior + total`` of each type, sum-normalised."""
    totals = tl.totals[lane, c]
    total = 0.0
    for t in range(totals.shape[0]):
        weights[t] = tl.template_prior + totals[t]
        total += weights[t]
    for t in range(totals.shape[0]):
        weights[t] /= total


@njit(cache=True, inline="always")
def learn(tl, lane, m, p, n_parents, children, task_types, values):
    """Each child adds the value of its atomic task to its type's total."""
    totals = tl.totals[lane]
    for k in range(task_types.shape[0]):
        totals[children[k], task_types[k]] += values[k]


@njit(cache=True)
def finish(tl, lane, m, weights):
    """The final allocation of every child (the state needs no materialising)."""
    for c in range(weights.shape[0]):
        allocate(tl, lane, m, c, weights[c])
