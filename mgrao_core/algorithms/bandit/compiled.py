"""``bandit``'s compiled steps: what the kernel calls for a lane of the family.

The template's signatures (``m``, the lane's parent groups, and the parent ``p`` go unused: the
learner has no groups), and :func:`learn` takes one more argument, the lane's allocation in force
``weights (children, n_types)``: the policy each returned task was a pull under. Each step indexes
the family's arrays itself; every write goes through a view the loop keeps using, or happens in a
function that is not inlined (docs/algorithms.md).
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


class BanditLanes(NamedTuple):
    """The family's lanes: ``preferences (lanes, children, n_types)``, ``bandit_baseline``, ``bandit_returns``.

    ``bandit_baseline`` and ``bandit_returns`` are ``(lanes, children)``; then the parameter.
    """

    preferences: np.ndarray
    bandit_baseline: np.ndarray
    bandit_returns: np.ndarray
    step: float


def lanes_of(arrays: Mapping[str, np.ndarray], params: System) -> BanditLanes:
    """:class:`BanditLanes` over the chunk's arrays (by name, as declared) and the parameter."""
    return BanditLanes(arrays["preferences"], arrays["bandit_baseline"], arrays["bandit_returns"],
                       float(params.bandit_step))


@njit(cache=True)
def allocate(bl, lane, m, c, weights):
    """Child ``c`` fixes its allocation for the episode: ``softmax(H)`` into ``weights``."""
    h = bl.preferences[lane, c]
    top = -np.inf
    for j in range(h.shape[0]):
        weights[j] = h[j]
        if h[j] > top:
            top = h[j]
    total = 0.0
    for j in range(h.shape[0]):
        weights[j] = math.exp(weights[j] - top)
        total += weights[j]
    for j in range(h.shape[0]):
        weights[j] /= total


@njit(cache=True, inline="always")
def learn(bl, lane, m, p, n_parents, children, task_types, values, weights):
    """Parent ``p``'s composite task came back: each atomic task is a pull of its type's arm by its child.

    For atomic task ``k`` (child ``c``, type ``t``, value ``atv``), under ``w = weights[c]``: the
    baseline takes ``atv`` in (running mean), then ``H[t] += step * (atv - baseline) * (1 - w[t])`` and
    ``H[j] -= step * (atv - baseline) * w[j]`` for ``j != t``.
    """
    h = bl.preferences[lane]
    baseline = bl.bandit_baseline[lane]
    returns = bl.bandit_returns[lane]
    n = h.shape[1]
    for k in range(task_types.shape[0]):
        c, t, value = children[k], task_types[k], values[k]
        returns[c] += 1.0
        baseline[c] += (value - baseline[c]) / returns[c]
        advantage = bl.step * (value - baseline[c])
        w = weights[c]
        for j in range(n):
            if j == t:
                h[c, j] += advantage * (1.0 - w[j])
            else:
                h[c, j] -= advantage * w[j]


@njit(cache=True)
def finish(bl, lane, m, weights):
    """Every child's final allocation ``softmax(H)`` into ``weights (children, n_types)``."""
    for c in range(weights.shape[0]):
        allocate(bl, lane, m, c, weights[c])
