"""MG-RAO's dense reference step: algorithms 1 and 2 applied literally, one child (or team of children) at a time.

What :mod:`mgrao_core.reference` runs for an MG-RAO configuration, built from
:mod:`mgrao_core.equations`, so that the tests can check the compiled steps against the paper's
equations.
"""

from __future__ import annotations

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.algorithms.base import Algorithm, ReferenceChild, World
from mgrao_core.algorithms.mgrao.family import parent_groups, teams
from mgrao_core.algorithms.state import System


class Child(ReferenceChild):
    """One child agent: its PW matrix, eligibility trace and per-group sample counts.

    Args:
        n_groups: parent groups ``m``.
        groups: the group of each parent.
        params: the system's parameters (MG-RAO's among them).
    """

    def __init__(self, n_groups: int, groups: np.ndarray, params: System) -> None:
        self.groups = groups
        self.params = params
        self.pw = np.full((n_groups, params.n_types), 1.0 / params.n_types)
        self.trace = np.zeros((n_groups, params.n_types))
        self.counts = np.zeros(n_groups)

    def allocation(self) -> np.ndarray:
        """Algorithm 2: the combined resource weights."""
        return eq.combined_weights(self.pw, self.counts, self.params.effective_temperature,
                                   self.params.group_blend == "dkl-and-count")

    def learn(self, parent: int, task_type: int, value: float) -> None:
        """Algorithm 1 for one returned absolute value, from a parent of group ``groups[parent]``."""
        group = int(self.groups[parent])
        self.counts[group] += 1
        self.trace = eq.eligibility_update(self.trace, group, task_type, self.params.trace_decay)
        self.pw = eq.pw_update(self.pw, self.trace, value, self.params.learning_rate)


class ResourceChild(ReferenceChild):
    """A child with several resources: one :class:`Child` (PW, trace, counts) per resource, the paper's ``pgw_{c,r,t}``.

    Under ``resource_credit = shared`` every resource's PW learns the whole returned value (so they never differ);
    under ``by-share`` resource ``r`` learns ``value * shares[r]`` (docs/model.md, "Several resources").
    """

    def __init__(self, n_groups: int, groups: np.ndarray, params: System) -> None:
        self.params = params
        self.resources = [Child(n_groups, groups, params) for _ in range(params.n_resources)]

    def allocation(self) -> np.ndarray:
        """``(n_resources, n_types)``: algorithm 2 on each resource's PW."""
        return np.stack([child.allocation() for child in self.resources])

    def learn(self, parent: int, task_type: int, value: float) -> None:
        """The whole value to every resource."""
        for child in self.resources:
            child.learn(parent, task_type, value)

    def learn_resources(self, parent: int, task_type: int, value: float, shares: np.ndarray) -> None:
        """Algorithm 1 on each resource's PW with its credit."""
        by_share = self.params.resource_credit == "by-share"
        for child, share in zip(self.resources, shares, strict=True):
            child.learn(parent, task_type, value * share if by_share else value)


def children(params: System, algorithm: Algorithm, world: World, seed: int) -> list[ReferenceChild]:
    """Each child of the system's learner, for ``algorithm`` (``mgrao-x:y`` or ``mgrao-max``).

    One :class:`Child` per team of ``y`` children (:func:`~mgrao_core.algorithms.mgrao.family.teams`), the same
    object for every member: the team's state learns every member's values in the order they come back, and each
    member allocates by it (with y = 1, one per child). With several resources, one :class:`ResourceChild` per team.
    """
    groups = parent_groups(params.n_parents, algorithm.n_groups)
    kind = ResourceChild if params.n_resources > 1 else Child
    shared = [kind(algorithm.n_groups, groups, params) for _ in range(params.n_children // algorithm.team_size)]
    return [shared[team] for team in teams(params.n_children, algorithm.team_size)]
