"""``bandit``'s dense reference step: the gradient bandit written out in numpy, one value at a time."""

from __future__ import annotations

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.algorithms.base import Algorithm, ReferenceChild, World
from mgrao_core.algorithms.state import System


class Child(ReferenceChild):
    """One child: a preference ``H`` per atomic type, the running mean of returned values, the allocation in force."""

    def __init__(self, params: System) -> None:
        self.h = np.zeros(params.n_types)
        self.baseline = 0.0
        self.returns = 0
        self.step = params.bandit_step
        self.w = eq.softmax(self.h)

    def allocation(self) -> np.ndarray:
        """``softmax(H)``; it stays the allocation in force (the policy of the pulls) until the next call."""
        self.w = eq.softmax(self.h)
        return self.w

    def learn(self, parent: int, task_type: int, value: float) -> None:
        """The baseline takes ``value`` in, then the gradient bandit's update for a pull of arm ``task_type``."""
        self.returns += 1
        self.baseline += (value - self.baseline) / self.returns
        advantage = self.step * (value - self.baseline)
        for j in range(len(self.h)):
            if j == task_type:
                self.h[j] += advantage * (1.0 - self.w[j])
            else:
                self.h[j] -= advantage * self.w[j]


def children(params: System, algorithm: Algorithm, world: World, seed: int) -> list[ReferenceChild]:
    """One :class:`Child` per child of the system."""
    return [Child(params) for _ in range(params.n_children)]
