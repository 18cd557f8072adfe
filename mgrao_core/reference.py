"""A plain per-agent simulator built from :mod:`mgrao_core.equations` and :mod:`mgrao_core.quality`: slow, dense.

It reads the same world and random streams as the engine, and each child is its algorithm family's
dense reference step (:meth:`Family.reference_children <mgrao_core.algorithms.base.Family.reference_children>`;
MG-RAO's applies algorithm 1 literally, a dense trace and weight update per returned value), so the
tests can check that the batched engine computes exactly the paper's equations, and the benchmark
can show what batching buys.

Its environment, :class:`SeedEnvironment` (one seed's parents, stepped one episode at a time with
the children's allocations given), is what the tests check :mod:`mgrao_core.env` against: the
environments outside learners act through run the engine's compiled episode, and must send back
what this module's reading of the paper's steps sends back.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.algorithms import family_of, parse_algorithm, task_share
from mgrao_core.algorithms.base import ReferenceChild
from mgrao_core.params import SystemParams
from mgrao_core.quality import atomic_quality, combine_resources
from mgrao_core.results import TaskCounts
from mgrao_core.world import (
    NEW_COMPOSITE,
    NEW_PROFILE,
    EpisodeDraws,
    EpisodeStreams,
    draw_links,
    draw_world,
    is_dynamic,
)


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
    """One parent agent: its composite type's atomic types, value profile, presence and estimates of each child.

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
    links: np.ndarray | None = None
    """In a sparse world, the children it offers its tasks to (``estimates[k, i]`` is of child ``links[i]``)."""

    def allocate(self, routing: np.ndarray, params: SystemParams) -> list[int]:
        """Task allocation: the child of each atomic task of this episode's composite task."""
        n = len(self.task_types)
        children = self.links if self.links is not None else np.arange(params.n_children)
        if len(children) == 1:
            return [int(children[0])] * n
        if params.routing == "per-composite":
            return [int(children[choose_child(self.estimates[0], routing[0], params)])] * n
        return [int(children[choose_child(self.estimates[k], routing[k], params)]) for k in range(n)]

    def observe(self, children: list[int], values: np.ndarray, taq: float, params: SystemParams) -> None:
        """Update the running mean of what each child gave back (of its slot among the links, in a sparse world)."""
        slot = {int(c): i for i, c in enumerate(self.links)} if self.links is not None else None
        children = children if slot is None else [slot[c] for c in children]
        returns = [(0, children[0], taq)] if params.routing == "per-composite" else [
            (k, c, values[k]) for k, c in enumerate(children)
        ]
        for k, c, value in returns:
            self.tries[k, c] += 1
            if self.tries[k, c] == 1:
                self.estimates[k, c] = value
            else:
                self.estimates[k, c] += (value - self.estimates[k, c]) / self.tries[k, c]


@dataclass(frozen=True)
class Episode:
    """What one episode of :class:`SeedEnvironment` did (the arrays are the environment's own: read, do not keep).

    Attributes:
        utility: the system utility, the sum of the composite qualities ``taq`` (and, under
            ``absent_tasks="counted"``, of the absent parents' ``absent_quality``).
        present: ``(n_parents,)`` which parents sent a composite task (present, and its type arrived).
        task_types: ``(n_parents, types_per_composite)`` each parent's atomic types in the episode
            (scheduled events and unpredictable parents change them).
        child_of: ``(n_parents, types_per_composite)`` the child each atomic task went to (-1: the
            parent was absent).
        values: ``(n_parents, types_per_composite)`` the absolute value ``atv`` each atomic task
            returned (0 for an absent parent).
        taqs: ``(n_parents,)`` each composite task's quality (0 for an absent parent).
        order: the present parents, in the order their values came back (paper step 5).
        shares: with several resources, ``(n_parents, types_per_composite, n_resources)`` each resource's share
            of each atomic task's quality (docs/model.md, "Several resources"); None with one.
    """

    utility: float
    present: np.ndarray
    task_types: np.ndarray
    child_of: np.ndarray
    values: np.ndarray
    taqs: np.ndarray
    order: list[int]
    shares: np.ndarray | None = None

    def returns(self) -> Iterator[tuple[int, int, int, float]]:
        """Every returned value in the order it came back: ``(parent, k, child, atv)``.

        Composite by composite in :attr:`order`, and within a composite atomic task by atomic task;
        that is the order in which each child learns from them.
        """
        for p in self.order:
            for k in range(self.child_of.shape[1]):
                yield p, k, int(self.child_of[p, k]), float(self.values[p, k])


class SeedEnvironment:
    """The simulated environment of one seed, one episode at a time: the paper's steps 1 to 5 without the children.

    The children's part (an allocation at the start of an episode, learning from each returned value)
    is the caller's: :func:`simulate` gives it to the algorithm families' reference steps, and the tests
    of :mod:`mgrao_core.env` to the actions they step the environments with. It reads the world and the
    episode streams of the seed exactly as the engine does.

    Args:
        params: the system's parameters.
        seed: the engine's seed: its world and per-episode draws.
        block: episodes drawn from the streams at a time (the numbers do not depend on it).
    """

    def __init__(self, params: SystemParams, seed: int, block: int = 256) -> None:
        self.params = params
        self.seed = seed
        self.world = draw_world(params, seed)
        self.episode = 0
        self._streams = EpisodeStreams(params, seed, self.world)
        self._block = max(1, block)
        self._draws = None
        self._start = 0
        choices = 1 if params.routing == "per-composite" else params.types_per_composite
        links = draw_links(params, seed)
        offered = params.children_offered
        self.parents = [
            Parent(self.world.parent_types[p].copy(), self.world.profiles[p].copy(),
                   np.full((choices, offered), params.initial_estimate), np.zeros((choices, offered), dtype=int),
                   links=None if links is None else links[p])
            for p in range(params.n_parents)
        ]
        shape = (params.n_parents, params.types_per_composite)
        self._child_of = np.full(shape, -1, dtype=np.int64)
        self._values = np.zeros(shape)
        self._taqs = np.zeros(params.n_parents)
        self._present = np.zeros(params.n_parents, dtype=bool)
        self._task_types = np.array(self.world.parent_types, dtype=np.int64)
        self._volatile = params.leave_probability > 0 or params.join_probability > 0
        self._dynamic = is_dynamic(params)
        self.tasks = TaskCounts()
        """What became of the atomic tasks so far, where tasks can fail (``task_need > 0``)."""

    def _draws_of(self, e: int) -> EpisodeDraws:
        if self._draws is None or e >= self._start + self._block:
            self._start = e
            self._draws = self._streams.draw(self._block)
        return self._draws

    def step(self, weights: Sequence[np.ndarray]) -> Episode:
        """One episode with each child's allocation ``weights[c]`` (``n_types`` weights) held throughout.

        With several resources ``weights[c]`` is ``(n_resources, n_types)``, one allocation per resource, or
        ``(n_types,)``, one split for every resource.

        Paper steps 1 (parents leave and rejoin) to 5 (the parents' estimates of their children take
        the returned values); the values themselves are in the answer, for the children.
        """
        params, parents, world = self.params, self.parents, self.world
        draws = self._draws_of(self.episode)
        e = self.episode - self._start
        self.episode += 1
        # 1. Composite tasks arrive at the parents present whose composite type arrives: the task stream's
        # changes (scheduled events, unpredictable parents), then volatility.
        for p, parent in enumerate(parents if self._dynamic else ()):
            if draws.changes[e, p] & NEW_PROFILE:
                parent.profile = draws.event_profiles[e, p].copy()
            if draws.changes[e, p] & NEW_COMPOSITE:
                parent.task_types = draws.event_types[e, p].copy()
                self._task_types[p] = parent.task_types
        for p, parent in enumerate(parents if self._volatile else ()):
            if parent.active and draws.volatility[e, p] < params.leave_probability:
                parent.active = False
            elif not parent.active and draws.volatility[e, p] < params.join_probability:
                parent.active = True
                if params.rejoin_profile == "new":
                    parent.profile = draws.new_profiles[e, p].copy()
        for p, parent in enumerate(parents):
            parent.sending = parent.active and (not self._dynamic or bool(draws.arrives[e, p]))
        # 2-3. Each parent that sends decomposes its task and allocates the atomic tasks.
        present = [p for p, parent in enumerate(parents) if parent.sending]
        assigned = {p: parents[p].allocate(draws.routing[e, p] if params.children_offered > 1 else None, params)
                    for p in present}
        # 4. Children perform the atomic tasks; composite qualities make the system utility.
        utility = 0.0
        child_of, values, taqs = self._child_of, self._values, self._taqs
        child_of[:] = -1
        values[:] = 0.0
        taqs[:] = 0.0
        for p in present:
            child_of[p] = assigned[p]
        children, types = child_of[present], self._task_types[present]
        load = 1.0
        if params.load_sharing:  # the instances of each type each child received this episode
            counts = np.zeros((params.n_children, params.n_types))
            np.add.at(counts, (children, types), 1.0)
            load = counts[children, types]
        shares = None
        if params.n_resources == 1:
            allocation = np.asarray(weights, dtype=float).reshape(params.n_children, params.n_types)
            resources = world.resources[children] / world.capability[children, types]  # capability scales h per type
            quality = atomic_quality(allocation[children, types], resources, params, load)
        else:  # several resources: the combination's effective weight and resource (docs/model.md)
            allocation = np.stack([np.broadcast_to(np.asarray(w, dtype=float), (params.n_resources, params.n_types))
                                   for w in weights])  # (children, R, n_types)
            per_weight = world.resource_per_type  # (children, R, n_types)
            w_eff, a_eff, task_shares = combine_resources(
                allocation[children, :, types], per_weight[children, :, types], world.needs[types],
                params.resource_combination)
            quality = atomic_quality(w_eff, a_eff, params, load)
            shares = np.zeros((params.n_parents, params.types_per_composite, params.n_resources))
            shares[present] = task_shares
        failed = np.zeros(quality.shape, dtype=bool)
        if params.tasks_can_fail:  # tasks that fail, and the hierarchy that completes some of them
            allocation = allocation if params.n_resources > 1 else allocation[:, None, :]
            quality, failed, task_shares = self._tasks_that_fail(children, types, allocation)
            if shares is not None:
                shares[present] = task_shares
        self._present[:] = False
        self._present[present] = True
        row = 0  # of quality: the present parents in order
        for p, parent in enumerate(parents):
            if not parent.sending:
                if params.absent_tasks == "counted" and not parent.active:
                    utility += params.effective_absent_quality
                continue
            ctv = eq.proportional_values(parent.profile, draws.noise[e, p], params.value_noise)
            taqs[p] = eq.composite_quality(ctv, quality[row])
            row += 1
            values[p] = np.where(failed[row - 1], 0.0, eq.absolute_values(ctv, taqs[p]))  # a failure returns 0
            utility += taqs[p]
        # 5. Values come back composite by composite, in a random order of parents: first to the
        # parents' estimates of their children (the children's learning is the caller's).
        order = [int(p) for p in draws.order[e] if parents[p].sending]
        if params.children_offered > 1:
            for p in order:
                parents[p].observe(assigned[p], values[p], taqs[p], params)
        return Episode(utility, self._present, self._task_types, child_of, values, taqs, order, shares)

    def _tasks_that_fail(self, children: np.ndarray, types: np.ndarray,
                         allocation: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each atomic task's quality where tasks can fail, task by task in the order of parents and their tasks.

        ``children`` and ``types`` are the present parents' (rows) atomic tasks', ``allocation (children, R,
        n_types)`` what each child gives each type of each resource (its tasks' share). A task gets
        ``x = w[c, last, t] * a[c, last, t]`` of the last resource (less what its child lent of the type) over the
        tasks that share it (under load sharing; else each gets it whole), and fails below the need
        (``equations.need_amount``); under ``borrow`` the first neighbour (``equations.neighbour``) that keeps the need
        for each of its own tasks of the type lends the shortfall, under ``hand-over`` the first one that meets the need
        for its tasks of the type with this one among them performs it, at ``1 - handover_cost`` of its quality (under
        load sharing the task moves to the tasks sharing its performer's amount, and a failed task shares none).
        Returns the qualities, which tasks failed (quality 0) and, with several resources, each resource's share of
        each quality.
        """
        params = self.params
        need = eq.need_amount(params.task_need, params.resource_mean, params.n_types)
        per_weight = self.world.resource_per_type  # (children, R, n_types)
        last = per_weight.shape[1] - 1
        available = allocation[:, last, :] * per_weight[:, last, :]
        lent = np.zeros_like(available)
        sharing = np.zeros_like(available)  # the tasks that share each child's amount of each type
        if params.load_sharing:
            np.add.at(sharing, (children, types), 1.0)
        else:  # each task gets the whole amount of its type
            sharing[children, types] = 1.0
        joins = 1.0 if params.load_sharing else 0.0  # what one task more or fewer adds to those sharing an amount
        n, ring = params.n_children, params.neighbours == "ring"
        asked = eq.n_neighbours(n, ring) if params.hierarchy != "none" else 0  # neighbours a failing task asks
        neighbours = [[eq.neighbour(c, i, n, ring) for i in range(asked)] for c in range(n)]
        outcome = np.full(children.shape, "own", dtype=object)
        performer = children.copy()
        for row, k in np.ndindex(children.shape):
            c, t = children[row, k], types[row, k]
            own = (available[c, t] - lent[c, t]) / sharing[c, t]
            if own >= need:
                continue
            outcome[row, k] = "failed"
            for d in neighbours[c]:
                room = available[d, t] - lent[d, t]
                if params.hierarchy == "borrow" and room - (need - own) >= need * sharing[d, t]:
                    lent[d, t] += need - own
                    outcome[row, k], performer[row, k] = "borrowed", d
                    break
                if params.hierarchy == "hand-over" and room >= need * max(sharing[d, t] + joins, 1.0):
                    sharing[d, t] += joins
                    sharing[c, t] -= joins
                    outcome[row, k], performer[row, k] = "handed over", d
                    break
            if outcome[row, k] == "failed":
                sharing[c, t] -= joins  # a failed task holds no share of its child's amount
        quality = np.zeros(children.shape)
        shares = np.zeros((*children.shape, per_weight.shape[1]))
        for row, k in np.ndindex(children.shape):
            if outcome[row, k] == "failed":
                continue
            c = children[row, k] if outcome[row, k] == "borrowed" else performer[row, k]
            t = types[row, k]
            w, a, tasks = allocation[c, :, t].copy(), per_weight[c, :, t], max(sharing[c, t], 1.0)
            if outcome[row, k] == "borrowed":
                w[last] = need * tasks / a[last]
            elif lent[c, t] > 0:
                w[last] -= lent[c, t] / a[last]
            if len(w) == 1:
                w_eff, a_eff = w[0], a[0]
            else:
                w_eff, a_eff, task_shares = combine_resources(w[None], a[None], self.world.needs[t][None],
                                                              params.resource_combination)
                w_eff, a_eff, shares[row, k] = w_eff[0], a_eff[0], task_shares[0]
            quality[row, k] = atomic_quality(w_eff, a_eff, params, tasks)
            if outcome[row, k] == "handed over":
                quality[row, k] *= 1.0 - params.handover_cost
        failed = outcome == "failed"
        helped = np.isin(outcome, ["borrowed", "handed over"])
        self.tasks += TaskCounts(children.size, int(failed.sum()), int(helped.sum()))
        return quality, failed, shares


def simulate(params: SystemParams, algorithm: str, seed: int,
             episodes: int) -> tuple[np.ndarray, list[ReferenceChild]]:
    """One run; returns the utility of every episode and the children's final state (:func:`simulate_run`'s)."""
    utilities, children, _ = simulate_run(params, algorithm, seed, episodes)
    return utilities, children


def simulate_run(params: SystemParams, algorithm: str, seed: int,
                 episodes: int) -> tuple[np.ndarray, list[ReferenceChild], TaskCounts]:
    """One run; returns the utility of every episode, the children's final state and what became of the tasks.

    Each child's tasks get ``task_share`` of its allocation (``learning_cost``, :func:`.equations.task_share`), or
    the share the child gives for the episode (:meth:`ReferenceChild.task_share`, after its allocation).
    """
    environment = SeedEnvironment(params, seed, block=episodes)
    alg = parse_algorithm(algorithm, params.n_parents)
    children = family_of(alg).reference_children(params, alg, environment.world, seed)
    share = task_share(alg, params)  # what learning leaves each child's tasks (equations.task_share)
    utilities = np.zeros(episodes)
    for e in range(episodes):
        allocations = [child.allocation() for child in children]
        episode = environment.step([child.task_share(share) * allocation
                                    for child, allocation in zip(children, allocations, strict=True)])
        utilities[e] = episode.utility
        for p, k, c, value in episode.returns():
            if episode.shares is None:
                children[c].learn(p, int(episode.task_types[p, k]), value)
            else:
                children[c].learn_resources(p, int(episode.task_types[p, k]), value, episode.shares[p, k])
    return utilities, children, environment.tasks
