"""A plain per-agent simulator built from :mod:`mgrao_core.equations` and :mod:`mgrao_core.quality`: slow, dense.

It reads the same world and random streams as the engine, and each child is its algorithm family's
dense reference step (:meth:`Family.reference_children <mgrao_core.algorithms.base.Family.reference_children>`;
MG-RAO's applies algorithm 1 literally, a dense trace and weight update per returned value), so the
tests can check that the batched engine computes exactly the paper's equations, and the benchmark
can show what batching buys.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.algorithms import family_of, parse_algorithm
from mgrao_core.algorithms.base import ReferenceChild
from mgrao_core.params import SystemParams
from mgrao_core.quality import atomic_quality
from mgrao_core.world import NEW_COMPOSITE, NEW_PROFILE, EpisodeStreams, draw_world, is_dynamic


def choose_child(estimates: np.ndarray, u: np.ndarray, params: SystemParams) -> int:
    """Epsilon-greedy with Boltzmann exploration among the other children (multi-child system)."""
    best_value = estimates.max()
    tied = np.flatnonzero(estimates == best_value)
    best = int(tied[0] if params.tie_break == "first" else tied[min(int(u[2] * len(tied)), len(tied) - 1)])
    if len(estimates) == 1 or u[0] >= params.epsilon:
        return best
    others = [c for c in range(len(estimates)) if c != best]
    top = max(estimates[c] for c in others)
    odds = [math.exp((estimates[c] - top) / params.boltzmann_temperature) for c in others]
    target = u[1] * sum(odds)
    for c, weight in zip(others, odds, strict=True):
        target -= weight
        if target < 0:
            return c
    return others[-1]


@dataclass
class Parent:
    """One parent agent: its composite type's atomic types, value profile, presence and running estimates of each child.

    ``estimates[k, c]`` is what child ``c`` gave back: per composite (``k = 0`` only) the
    composite quality, per task the absolute value of atomic task ``k``. ``sending``: whether it sends a
    composite task in the current episode (present, and its composite type arrives).
    """

    task_types: np.ndarray
    profile: np.ndarray
    estimates: np.ndarray
    tries: np.ndarray
    active: bool = True
    sending: bool = True

    def allocate(self, routing: np.ndarray, params: SystemParams) -> list[int]:
        """Task allocation: the child of each atomic task of this episode's composite task."""
        n = len(self.task_types)
        if params.n_children == 1:
            return [0] * n
        if params.routing == "per-composite":
            return [choose_child(self.estimates[0], routing[0], params)] * n
        return [choose_child(self.estimates[k], routing[k], params) for k in range(n)]

    def observe(self, children: list[int], values: np.ndarray, taq: float, params: SystemParams) -> None:
        """Update the running mean of what each child gave back."""
        returns = [(0, children[0], taq)] if params.routing == "per-composite" else [
            (k, c, values[k]) for k, c in enumerate(children)
        ]
        for k, c, value in returns:
            self.tries[k, c] += 1
            if self.tries[k, c] == 1:
                self.estimates[k, c] = value
            else:
                self.estimates[k, c] += (value - self.estimates[k, c]) / self.tries[k, c]


def simulate(params: SystemParams, algorithm: str, seed: int,
             episodes: int) -> tuple[np.ndarray, list[ReferenceChild]]:
    """One run; returns the utility of every episode and the children's final state."""
    world = draw_world(params, seed)
    draws = EpisodeStreams(params, seed, world).draw(episodes)
    dynamic = is_dynamic(params)
    alg = parse_algorithm(algorithm, params.n_parents)
    children = family_of(alg).reference_children(params, alg, world, seed)
    choices = 1 if params.routing == "per-composite" else params.types_per_composite
    parents = [
        Parent(world.parent_types[p].copy(), world.profiles[p].copy(),
               np.full((choices, params.n_children), params.initial_estimate),
               np.zeros((choices, params.n_children), dtype=int))
        for p in range(params.n_parents)
    ]
    utilities = np.zeros(episodes)
    for e in range(episodes):
        # 1. Composite tasks arrive at the parents present whose composite type arrives: the task stream's
        # changes (scheduled events, unpredictable parents), then volatility.
        for p, parent in enumerate(parents):
            if dynamic and draws.changes[e, p] & NEW_PROFILE:
                parent.profile = draws.event_profiles[e, p].copy()
            if dynamic and draws.changes[e, p] & NEW_COMPOSITE:
                parent.task_types = draws.event_types[e, p].copy()
        for p, parent in enumerate(parents):
            if parent.active and draws.volatility[e, p] < params.leave_probability:
                parent.active = False
            elif not parent.active and draws.volatility[e, p] < params.join_probability:
                parent.active = True
                if params.rejoin_profile == "new":
                    parent.profile = draws.new_profiles[e, p].copy()
        for p, parent in enumerate(parents):
            parent.sending = parent.active and (not dynamic or bool(draws.arrives[e, p]))
        weights = [child.allocation() for child in children]
        # 2-3. Each present parent decomposes its task and allocates the atomic tasks.
        present = [p for p, parent in enumerate(parents) if parent.sending]
        assigned = {p: parents[p].allocate(draws.routing[e, p] if params.n_children > 1 else None, params)
                    for p in present}
        load = np.zeros((params.n_children, params.n_types))
        for p in present:
            for c, t in zip(assigned[p], parents[p].task_types, strict=True):
                load[c, t] += 1
        # 4. Children perform the atomic tasks; composite qualities make the system utility.
        values: dict[int, np.ndarray] = {}
        taqs: dict[int, float] = {}
        for p, parent in enumerate(parents):
            if not parent.sending:
                if params.absent_tasks == "counted" and not parent.active:
                    utilities[e] += params.effective_absent_quality
                continue
            ctv = eq.proportional_values(parent.profile, draws.noise[e, p], params.value_noise)
            quality = np.array([
                atomic_quality(weights[c][t], world.resources[c] / world.capability[c, t], params,
                               load[c, t] if params.load_sharing else 1.0)
                for c, t in zip(assigned[p], parent.task_types, strict=True)
            ])
            taqs[p] = eq.composite_quality(ctv, quality)
            values[p] = eq.absolute_values(ctv, taqs[p])
            utilities[e] += taqs[p]
        # 5. Values come back composite by composite, in a random order of parents.
        for p in draws.order[e]:
            if not parents[p].sending:
                continue
            if params.n_children > 1:
                parents[p].observe(assigned[p], values[p], taqs[p], params)
            for k, c in enumerate(assigned[p]):
                children[c].learn(int(p), int(parents[p].task_types[k]), values[p][k])
    return utilities, children
