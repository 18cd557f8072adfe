"""``independent-q``'s compiled steps: what the kernel calls for a lane of the family.

Each step takes the family's lanes (:class:`IndependentQLanes`, one flat NamedTuple) and the lane's
index, and indexes the arrays itself, with the template's signatures (``m``, the lane's parent
groups, and the parent ``p`` go unused: the learner has no groups). docs/algorithms.md says which
writes numba's parallel loop would drop once inlined: here every write goes through a view the loop
keeps using, or happens in a function that is not inlined.
"""

from __future__ import annotations

import mgrao_core._numba_cache  # noqa: F401  (first: picks a writable numba cache before numba loads)

# isort: split
import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np
from numba import njit

from mgrao_core.algorithms.state import System


class IndependentQLanes(NamedTuple):
    """The family's lanes: ``q_values (lanes, children, n_types)``, then its parameters."""

    q_values: np.ndarray
    learning_rate: float
    temperature: float


def lanes_of(arrays: Mapping[str, np.ndarray], params: System) -> IndependentQLanes:
    """:class:`IndependentQLanes` over the chunk's arrays (by name, as declared) and the parameters."""
    return IndependentQLanes(arrays["q_values"], float(params.q_learning_rate), float(params.q_temperature))


@njit(cache=True)
def softmax(x, temperature, out):
    """``softmax(x / temperature)`` into ``out``, as :func:`mgrao_core.equations.softmax` computes it."""
    top = -np.inf
    for j in range(x.shape[0]):
        v = x[j] / temperature
        out[j] = v
        if v > top:
            top = v
    total = 0.0
    for j in range(x.shape[0]):
        out[j] = math.exp(out[j] - top)
        total += out[j]
    for j in range(x.shape[0]):
        out[j] /= total


@njit(cache=True)
def allocate(ql, lane, m, c, weights):
    """Child ``c`` fixes its allocation for the episode: ``softmax(Q / q_temperature)`` into ``weights``."""
    softmax(ql.q_values[lane, c], ql.temperature, weights)


@njit(cache=True, inline="always")
def learn(ql, lane, m, p, n_parents, children, task_types, values):
    """Parent ``p``'s composite task came back: atomic task ``k`` of type ``t`` moves ``Q[t]`` of ``children[k]``.

    ``Q[t] += q_learning_rate * (values[k] - Q[t])``, value by value in the order of the tasks.
    """
    q = ql.q_values[lane]
    rate = ql.learning_rate
    for k in range(task_types.shape[0]):
        c, t = children[k], task_types[k]
        q[c, t] += rate * (values[k] - q[c, t])


@njit(cache=True)
def finish(ql, lane, m, weights):
    """Every child's final allocation into ``weights (children, n_types)`` (the state needs no materialising)."""
    for c in range(weights.shape[0]):
        allocate(ql, lane, m, c, weights[c])
