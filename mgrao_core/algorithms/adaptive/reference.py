"""``mgrao-adaptive:x``'s dense reference step: MG-RAO's reference child whose parent groups are re-formed.

Algorithms 1 and 2 are MG-RAO's dense reference (:class:`mgrao_core.algorithms.mgrao.reference.Child`,
literally the paper's equations); the statistics and the regrouping are written again here in plain
numpy (a sort by :func:`numpy.lexsort`, the matching by overlap counts), so that the tests check the
compiled ones against a second implementation of the rule (:mod:`mgrao_core.algorithms.adaptive.family`).
"""

from __future__ import annotations

import numpy as np

from mgrao_core.algorithms.base import Algorithm, ReferenceChild, World
from mgrao_core.algorithms.mgrao.family import parent_groups
from mgrao_core.algorithms.mgrao.reference import Child as MgraoChild
from mgrao_core.algorithms.state import System


class Child(MgraoChild):
    """One child: MG-RAO's PW, trace and counts over ``n_groups`` rows, and its statistics of every parent.

    ``groups`` (each parent's row) changes at every regrouping; ``history`` lists every membership
    after the first and each regrouping (all of them: only the engine's record is bounded).
    """

    def __init__(self, n_groups: int, params: System) -> None:
        super().__init__(n_groups, parent_groups(params.n_parents, n_groups), params)
        n = params.n_parents
        self.returns = np.zeros(n)
        self.signature = [[0.0, 0.0] for _ in range(n)]  # running mean, sum of squared deviations
        self.spread = [[0.0, 0.0] for _ in range(n)]
        self.episodes = 0
        self.history = [self.groups.copy()]
        self.pending: tuple[int, list[int], list[float]] | None = None  # the composite being received

    def allocation(self) -> np.ndarray:
        """An episode begins: the regrouping when due, then algorithm 2."""
        self._take_in()
        if self.episodes > 0 and self.episodes % self.params.regroup_every == 0:
            self.regroup()
            self.history.append(self.groups.copy())
        self.episodes += 1
        return super().allocation()

    def learn(self, parent: int, task_type: int, value: float) -> None:
        """Algorithm 1 for the parent's row; the value joins the parent's composite for the statistics."""
        if self.pending is not None and self.pending[0] != parent:
            self._take_in()
        if self.pending is None:
            self.pending = (parent, [], [])
        self.pending[1].append(task_type)
        self.pending[2].append(value)
        super().learn(parent, task_type, value)

    def _take_in(self) -> None:
        """The statistics take in the composite received (its values come one after another)."""
        if self.pending is None:
            return
        parent, types, values = self.pending
        self.pending = None
        type_sum = 0.0
        value_sum = 0.0
        for t in types:
            type_sum += t
        for v in values:
            value_sum += v
        self.returns[parent] += 1.0
        for stats, x in ((self.signature, type_sum / len(types)),
                         (self.spread, max(values) / value_sum if value_sum > 0.0 else 0.0)):
            mean, m2 = stats[parent]
            delta = x - mean
            mean += delta / self.returns[parent]
            stats[parent] = [mean, m2 + delta * (x - mean)]

    def regroup(self) -> None:
        """Order the parents by the rule, cut them into runs, give each run the old row it overlaps most."""
        n, m = len(self.groups), self.pw.shape[0]
        seen = self.returns > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            sig_var = np.where(seen, np.array([s[1] for s in self.signature]) / self.returns, np.inf)
            spread_var = np.where(seen, np.array([s[1] for s in self.spread]) / self.returns, np.inf)
        sig_mean = np.array([s[0] for s in self.signature])
        keys = (np.arange(n), spread_var, sig_mean, sig_var) if self.params.regroup_by == "types" else (
            np.arange(n), spread_var, sig_var)
        order = np.lexsort(keys)
        run = np.empty(n, dtype=np.int64)
        run[order] = (np.arange(n) * m) // n
        new = np.empty(n, dtype=np.int64)
        free = list(range(m))
        for g in range(m):
            overlap = np.bincount(self.groups[run == g], minlength=m)
            best = max(free, key=lambda i: (overlap[i], -i))
            free.remove(best)
            new[run == g] = best
        self.groups[:] = new


def children(params: System, algorithm: Algorithm, world: World, seed: int) -> list[ReferenceChild]:
    """One :class:`Child` per child of the system, for ``mgrao-adaptive:x``."""
    return [Child(algorithm.n_groups, params) for _ in range(params.n_children)]
