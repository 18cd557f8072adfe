"""What a child sees of an episode, compiled: the environments' observations (:mod:`mgrao_core.env`).

A child sees only what came back to it: each atomic task it received, its type and the absolute value
returned for it, and the order of its returns (composite by composite in the episode's order of parents,
then task by task: the order in which MG-RAO learns). Its reward is the sum of those values, added in
that order.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def child_observations(sending, child_of, values, task_types, order, received, task_type, value, position, rewards):
    """Every child's observation of one episode of every world, into the output arrays (zeros on entry).

    In, first axis the world: ``sending (worlds, parents)``, ``child_of``, ``values``, ``task_types (worlds,
    parents, types_per_composite)`` and ``order (worlds, parents)`` (:class:`mgrao_core.stepper.Outcome`).
    Out, first axes child and world: ``received`` (int8), ``task_type`` (int64), ``value`` and ``position``
    (int64), each ``(children, worlds, parents, types_per_composite)``, nonzero only where the child received
    the task; ``rewards (children, worlds)``.
    """
    n_children = received.shape[0]
    n_worlds, n_parents, k = child_of.shape
    returned = np.zeros(n_children, dtype=np.int64)
    for w in range(n_worlds):
        returned[:] = 0
        for i in range(n_parents):
            p = order[w, i]
            if not sending[w, p]:
                continue
            for j in range(k):
                c = child_of[w, p, j]
                received[c, w, p, j] = 1
                task_type[c, w, p, j] = task_types[w, p, j]
                value[c, w, p, j] = values[w, p, j]
                position[c, w, p, j] = returned[c]
                returned[c] += 1
                rewards[c, w] += values[w, p, j]
