"""``mgrao-balance``'s dense reference step: MG-RAO's reference child whose groups split as the rule says.

Algorithms 1 and 2 are MG-RAO's dense reference (:class:`mgrao_core.algorithms.mgrao.reference.Child`, literally
the paper's equations) on the child's present rows; the decision and the split are written again here in plain
Python and numpy (:mod:`mgrao_core.algorithms.balance.family` states the rule), so that the tests check the
compiled ones against a second implementation.
"""

from __future__ import annotations

import math

import numpy as np

from mgrao_core import equations
from mgrao_core.algorithms import Algorithm, learned_by_max
from mgrao_core.algorithms.balance.family import FAMILY, next_split
from mgrao_core.algorithms.base import ReferenceChild, World
from mgrao_core.algorithms.mgrao.family import parent_groups
from mgrao_core.algorithms.mgrao.reference import Child as MgraoChild
from mgrao_core.algorithms.state import System


class Child(MgraoChild):
    """One child: MG-RAO's PW, trace and counts over its present groups, and the rule's state.

    ``history`` lists the group count after each decision (the first entry: 1, before any).
    """

    def __init__(self, bound: int, params: System) -> None:
        super().__init__(1, parent_groups(params.n_parents, 1), params)
        self.bound = bound
        self.last_split = 1
        self.settled = False
        self.episodes = 0
        self.history = [1]
        self.by_max = learned_by_max(params)

    @property
    def n_groups(self) -> int:
        """The child's present number of groups."""
        return self.pw.shape[0]

    def allocation(self) -> np.ndarray:
        """An episode begins: the decision when due, then algorithm 2."""
        if self.episodes > 0 and self.episodes % self.params.balance_every == 0:
            self.decide()
            self.history.append(self.n_groups)
        self.episodes += 1
        return super().allocation()

    def task_share(self, share: float) -> float:
        """What learning its present groups leaves its tasks (``share``, priced for the bound, is not used)."""
        learned = FAMILY.learned_for(self.n_groups, self.params)
        return equations.task_share(self.params.learning_cost, learned, self.by_max)

    def divergence(self) -> float:
        """The mean over rows of each row's symmetric KL divergence to its siblings' mean (the last split's)."""
        m, q = self.n_groups, self.last_split
        total = 0.0
        for i in range(m):
            siblings = range((i // q) * q, (i // q) * q + q)
            for j in range(self.pw.shape[1]):
                mu = 0.0
                for s in siblings:
                    mu += float(self.pw[s, j])
                mu /= q
                r = float(self.pw[i, j])
                if r > 0.0 and mu > 0.0:
                    total += (r - mu) * math.log(r / mu)
        return total / m

    def decide(self) -> None:
        """Split when the rule says so, or settle for good."""
        m = self.n_groups
        if self.settled or m >= self.bound:
            return
        if m == 1 or self.divergence() >= self.params.balance_tolerance * self.params.learning_cost:
            q = next_split(m, self.bound)
            self.pw = np.repeat(self.pw, q, axis=0)
            self.trace = np.repeat(self.trace, q, axis=0)
            self.counts = np.repeat(self.counts / q, q)
            self.groups = parent_groups(self.params.n_parents, m * q)
            self.last_split = q
        else:
            self.settled = True


def children(params: System, algorithm: Algorithm, world: World, seed: int) -> list[ReferenceChild]:
    """One :class:`Child` per child of the system, for ``mgrao-balance[:M]``."""
    return [Child(algorithm.n_groups, params) for _ in range(params.n_children)]
