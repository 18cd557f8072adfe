"""A plain per-agent simulator built from :mod:`mgrao_core.equations`: slow, dense, obvious.

It reads the same world and random streams as the engine and applies algorithm 1 literally (a
dense trace and weight update per returned value), so the tests can check that the batched
engine computes exactly the paper's equations, and the benchmark can show what batching buys.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.algorithms import parent_groups, parse_algorithm
from mgrao_core.oracle import oracle_weights
from mgrao_core.params import SystemParams
from mgrao_core.world import EpisodeStreams, draw_world


@dataclass
class Child:
    """One child agent: its PW matrix, eligibility trace and per-group sample counts."""

    n_groups: int
    n_types: int
    fixed: np.ndarray | None = None
    pw: np.ndarray = field(init=False)
    trace: np.ndarray = field(init=False)
    counts: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.pw = np.full((self.n_groups, self.n_types), 1.0 / self.n_types)
        self.trace = np.zeros((self.n_groups, self.n_types))
        self.counts = np.zeros(self.n_groups)

    def allocation(self, temperature: float) -> np.ndarray:
        """Algorithm 2: the combined resource weights (or the fixed ones of a baseline)."""
        if self.fixed is not None:
            return self.fixed
        return eq.combined_weights(self.pw, self.counts, temperature)

    def learn(self, group: int, task_type: int, value: float, params: SystemParams) -> None:
        """Algorithm 1 for one returned absolute value."""
        self.counts[group] += 1
        self.trace = eq.eligibility_update(self.trace, group, task_type, params.trace_decay)
        self.pw = eq.pw_update(self.pw, self.trace, value, params.learning_rate)


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


def simulate(params: SystemParams, algorithm: str, seed: int, episodes: int) -> tuple[np.ndarray, list[Child]]:
    """One run; returns the utility of every episode and the children's final state."""
    world = draw_world(params, seed)
    draws = EpisodeStreams(params, seed).draw(episodes)
    alg = parse_algorithm(algorithm, params.n_parents)
    fixed = None
    if alg.kind == "uniform":
        fixed = np.full(params.n_types, 1.0 / params.n_types)
    elif alg.kind == "oracle":
        fixed = oracle_weights(params, world, seed)
    children = [Child(max(alg.n_groups, 1), params.n_types, fixed) for _ in range(params.n_children)]
    groups = parent_groups(params.n_parents, alg.n_groups) if alg.kind == "mgrao" else None
    shape = (params.n_parents, params.types_per_composite, params.n_children)
    estimates = np.full(shape, params.initial_estimate)
    tries = np.zeros(shape, dtype=int)
    active = np.ones(params.n_parents, dtype=bool)
    profiles = world.profiles.copy()
    utilities = np.zeros(episodes)
    for e in range(episodes):
        for p in range(params.n_parents):
            if active[p] and draws.volatility[e, p] < params.leave_probability:
                active[p] = False
            elif not active[p] and draws.volatility[e, p] < params.join_probability:
                active[p] = True
                if params.rejoin_profile == "new":
                    profiles[p] = draws.new_profiles[e, p]
        weights = [child.allocation(params.effective_temperature) for child in children]
        assigned: dict[int, list[int]] = {}
        values: dict[int, np.ndarray] = {}
        for p in np.flatnonzero(active):
            assigned[p] = [
                0 if params.n_children == 1 else choose_child(estimates[p, k], draws.routing[e, p, k], params)
                for k in range(params.types_per_composite)
            ]
            ctv = eq.proportional_values(profiles[p], draws.noise[e, p], params.value_noise)
            shares = np.array([weights[c][t] for c, t in zip(assigned[p], world.parent_types[p], strict=True)])
            quality = eq.atomic_quality(shares, params.n_types, params.quality_at_uniform, params.quality_floor)
            taq = eq.composite_quality(ctv, quality)
            values[p] = eq.absolute_values(ctv, taq)
            utilities[e] += taq
        for p in draws.order[e]:
            if not active[p]:
                continue
            for k, c in enumerate(assigned[p]):
                if params.n_children > 1:
                    tries[p, k, c] += 1
                    if tries[p, k, c] == 1:
                        estimates[p, k, c] = values[p][k]
                    else:
                        estimates[p, k, c] += (values[p][k] - estimates[p, k, c]) / tries[p, k, c]
                if groups is not None:
                    children[c].learn(int(groups[p]), int(world.parent_types[p, k]), values[p][k], params)
    return utilities, children
