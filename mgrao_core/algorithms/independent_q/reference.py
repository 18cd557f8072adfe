"""``independent-q``'s dense reference step: the update and the allocation written out in numpy."""

from __future__ import annotations

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.algorithms.base import Algorithm, ReferenceChild, World
from mgrao_core.algorithms.state import System


class Child(ReferenceChild):
    """One child: its running value ``Q`` per atomic type, starting at 0."""

    def __init__(self, params: System) -> None:
        self.q = np.zeros(params.n_types)
        self.learning_rate = params.q_learning_rate
        self.temperature = params.q_temperature

    def allocation(self) -> np.ndarray:
        """``softmax(Q / q_temperature)``."""
        return eq.softmax(self.q, self.temperature)

    def learn(self, parent: int, task_type: int, value: float) -> None:
        """``Q[t] += q_learning_rate * (atv - Q[t])`` for the returned absolute value of type ``t``."""
        self.q[task_type] += self.learning_rate * (value - self.q[task_type])


def children(params: System, algorithm: Algorithm, world: World, seed: int) -> list[ReferenceChild]:
    """One :class:`Child` per child of the system."""
    return [Child(params) for _ in range(params.n_children)]
