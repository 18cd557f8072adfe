"""Worlds stepped one episode at a time on the compiled kernel, the children's allocations given from outside.

In a run (:mod:`mgrao_core.runner`) an algorithm family allocates and learns inside the kernel. Here a
learner outside it does: :meth:`SteppedWorlds.step` takes every world's allocations, runs one episode of
every world in one call of :func:`mgrao_core.engine.run_block` (lanes of a fixed family, which hold
whatever allocation they are given), and returns what came back. World ``i`` is the engine's seed
``seeds[i]``: its world, and its per-episode draws taken from the seed's streams a block of episodes
at a time as the runner takes them, so the same allocations give the engine's numbers. Some worlds can
start afresh while the others go on (:meth:`SteppedWorlds.renew`): a renewed world is the world of its new
seed from that seed's first episode, wherever the others are. The environments of :mod:`mgrao_core.env` are
built on it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any, NamedTuple

import numba
import numpy as np

from mgrao_core import engine
from mgrao_core.algorithms import LEARNERS, parse_algorithm
from mgrao_core.lanes import allocate_lanes
from mgrao_core.params import SystemParams
from mgrao_core.runner import block_draws, kernel_failing, kernel_links, kernel_worlds
from mgrao_core.world import EpisodeStreams, draw_links, draw_world

_NO_LEARNERS = (None,) * len(LEARNERS)


class Outcome(NamedTuple):
    """What one episode of every world did, first axis the world (arrays of the stepper: read, do not keep).

    Attributes:
        utility: ``(worlds,)`` the system utility.
        sending: ``(worlds, parents)`` the parents that sent a composite task (present, and its type arrived).
        child_of: ``(worlds, parents, types_per_composite)`` the child each atomic task went to.
        values: ``(worlds, parents, types_per_composite)`` the absolute value ``atv`` it returned.
        task_types: ``(worlds, parents, types_per_composite)`` each atomic task's type in the episode.
        order: ``(worlds, parents)`` the parents in the order their values came back (paper step 5).

    ``child_of`` and ``values`` mean nothing where ``sending`` is False.
    """

    utility: np.ndarray
    sending: np.ndarray
    child_of: np.ndarray
    values: np.ndarray
    task_types: np.ndarray
    order: np.ndarray


class SteppedWorlds:
    """The worlds of ``seeds`` for ``params``, at episode 0.

    ``block`` episodes are drawn from each seed's streams at a time (the numbers do not depend on it).

    Attributes:
        params: the parameter set.
        seeds: the engine's seed of each world (a renewed world's new seed).
        block: episodes drawn at a time.
        episode: steps taken so far (every world plays one episode a step); :attr:`played` counts each
            world's own episodes since it began.
    """

    def __init__(self, params: SystemParams, seeds: Sequence[int], block: int = 256) -> None:
        self.params = p = params
        self.block = max(1, int(block))
        self.seeds = tuple(int(s) for s in seeds)
        worlds = [draw_world(p, seed) for seed in self.seeds]
        self._uniform = parse_algorithm("uniform", p.n_parents)
        self._arrays = allocate_lanes(p, [self._uniform], len(worlds))
        self._arrays["profiles"][:] = np.stack([world.profiles for world in worlds])
        self._arrays["parent_types"][:] = np.stack([world.parent_types for world in worlds])
        self._lanes = engine.Lanes(**{name: self._arrays[name] for name in engine.Lanes._fields})
        self._worlds, self._several = kernel_worlds(p, worlds)
        self._links = kernel_links(p, self.seeds)
        self._environment = engine.environment_of(p)
        self._streams = [EpisodeStreams(p, seed, world) for seed, world in zip(self.seeds, worlds, strict=True)]
        n, shape = len(worlds), (len(worlds), p.n_parents, p.types_per_composite)
        several = p.n_resources if p.n_resources > 1 else 0
        self._outside = engine.Outside(resource_weights=np.zeros((n, p.n_children, several, p.n_types)),
                                       sending=np.zeros((n, p.n_parents), np.bool_),
                                       child_of=np.zeros(shape, np.int64), values=np.zeros(shape))
        self._utility = np.zeros((n, 1))
        self._failing = kernel_failing(p, self._arrays)
        self._draws: list[engine.Draws] | None = None
        self._block: list[np.ndarray] = []  # the block's draws, episode first (self._draws are views of them)
        self._kernel: Callable[..., None] | None = None
        self._observer: Callable[..., None] | None = None
        self._start = 0
        self.episode = 0
        self._began = np.zeros(n, np.int64)  # the step at which each world began
        self._together: int | None = 0  # the step at which every world began, while they began together

    @property
    def played(self) -> np.ndarray:
        """``(worlds,)`` the episodes each world has played since it began (a renewed world: since its renewal)."""
        return self.episode - self._began

    @property
    def played_together(self) -> int | None:
        """The episodes every world has played, while every world began at the same step; None otherwise."""
        return None if self._together is None else self.episode - self._together

    def set_task_share(self, share: np.ndarray) -> None:
        """Each child's share of its resources that its tasks get, ``(worlds, children)`` or broadcast to it.

        What learning leaves them (``learning_cost``, :func:`mgrao_core.equations.task_share`): the kernel
        multiplies each weight by it where a task's quality is computed, as in a run (``Lanes.task_share``).
        """
        self._arrays["task_share"][:] = share

    def renew(self, worlds: Sequence[int], seeds: Sequence[int]) -> None:
        """Start worlds ``worlds`` afresh, ``worlds[j]`` as the engine's seed ``seeds[j]``; the others go on.

        A renewed world is a new :class:`SteppedWorlds` of its seed would be: its world (resources, links), the
        lanes' state as at episode 0 (every parent present, estimates at their start) and its draws from the
        seed's first episode on, the rest of the current block drawn from its new streams now. The children's
        task shares (:meth:`set_task_share`) are the learner's and stay.
        """
        rows = np.asarray(worlds, dtype=np.int64)
        if not len(rows):
            return
        p = self.params
        fresh = [draw_world(p, int(seed)) for seed in seeds]
        lanes = allocate_lanes(p, [self._uniform], len(rows))
        lanes["profiles"][:] = np.stack([world.profiles for world in fresh])
        lanes["parent_types"][:] = np.stack([world.parent_types for world in fresh])
        for name, array in self._arrays.items():
            if name not in ("seed_index", "task_share"):  # a lane's index is its world's; its share the learner's
                array[rows] = lanes[name]
        renewed_worlds, renewed_several = kernel_worlds(p, fresh)
        self._worlds.resources[rows] = renewed_worlds.resources
        if self._several is not None:
            self._several.per_resource[rows] = renewed_several.per_resource
            self._several.needs[rows] = renewed_several.needs
        if self._links is not None:
            self._links[rows] = np.stack([draw_links(p, int(seed)) for seed in seeds])
        seeds_now = list(self.seeds)
        for row, seed, world in zip(rows.tolist(), seeds, fresh, strict=True):
            seeds_now[row] = int(seed)
            self._streams[row] = EpisodeStreams(p, int(seed), world)
        self.seeds = tuple(seeds_now)
        offset = self.episode - self._start
        if self._draws is not None and offset < self.block:  # the rest of this block: the renewed worlds' first
            drawn = block_draws([self._streams[row].draw(self.block - offset) for row in rows.tolist()])
            for master, new in zip(self._block, drawn, strict=True):
                master[offset:, rows, 0] = np.moveaxis(new, 1, 0)
        self._began[rows] = self.episode
        self._together = self.episode if (self._began == self.episode).all() else None

    @property
    def resources(self) -> np.ndarray:
        """Each child's resource per unit of weight of each type, its world's.

        ``(worlds, children, n_types)``; with several resources ``(worlds, children, R, n_types)``, each relative
        to the type's need of it.
        """
        return self._worlds.resources if self._several is None else self._several.per_resource

    @property
    def present(self) -> np.ndarray:
        """``(worlds, parents)`` the parents present in the last episode (at the start: before it)."""
        return self._lanes.active

    def step(self, weights: np.ndarray) -> Outcome:
        """One episode of every world, child ``c`` of world ``i`` holding the allocation ``weights[i, c]``.

        ``weights (worlds, children, n_types)``, with several resources ``(worlds, children, R, n_types)`` (one
        allocation per resource), are taken as they are: sum-normalised, finite, at least 0 (the environments
        check and normalise actions).
        """
        if self._draws is None or self.episode >= self._start + self.block:
            self._start = self.episode
            self._block, self._draws = _by_episode(block_draws([stream.draw(self.block) for stream in self._streams]))
        draws = self._draws[self.episode - self._start]
        if self._several is None:
            self._arrays["fixed_weights"][:] = weights
        else:  # each resource's allocation; the lanes' weights are the first resource's, as in a run
            self._arrays["fixed_weights"][:] = weights[:, :, 0]
            self._outside.resource_weights[:] = weights
        arguments = (self._lanes, self._worlds, self._several, self._links, draws, self._environment, self._utility,
                     self._outside, self._failing, *_NO_LEARNERS)
        set_threads, get_threads = _thread_functions()
        threads = get_threads()
        set_threads(1)  # one episode is too short for numba's threads to pay for their start
        try:
            if self._kernel is None:
                self._kernel = _compiled(engine.run_block, arguments)
            else:
                self._kernel(*arguments)
        finally:
            set_threads(threads)
        self.episode += 1
        outside = self._outside
        return Outcome(self._utility[:, 0], outside.sending, outside.child_of, outside.values,
                       self._lanes.parent_types, draws.order[:, 0])

    def observe(self, outcome: Outcome) -> tuple[dict[str, np.ndarray], np.ndarray]:
        """Every child's observation of ``outcome`` and its reward (:mod:`mgrao_core.engine.observation`).

        ``outcome`` is the last :meth:`step`'s: the compiled entry trusts its arrays' types, so give it no other.

        Returns:
            New arrays: the observation's entries by key (``received``, ``task_type``, ``value``,
            ``position``), each ``(children, worlds, parents, types_per_composite)``, and the rewards
            ``(children, worlds)``.
        """
        shape = (self.params.n_children, *outcome.child_of.shape)
        entries = {"received": np.zeros(shape, np.int8), "task_type": np.zeros(shape, np.int64),
                   "value": np.zeros(shape), "position": np.zeros(shape, np.int64)}
        rewards = np.zeros(shape[:2])
        arguments = (outcome.sending, outcome.child_of, outcome.values, outcome.task_types, outcome.order,
                     entries["received"], entries["task_type"], entries["value"], entries["position"], rewards)
        if self._observer is None:
            self._observer = _compiled(engine.child_observations, arguments)
        else:
            self._observer(*arguments)
        return entries, rewards


@functools.cache
def _thread_functions() -> tuple[Callable[..., Any], Callable[..., Any]]:
    """Numba's setter and getter of the calling thread's number of threads, once its threads are launched.

    ``numba.set_num_threads`` and ``get_num_threads`` check, under a lock, that the threads are launched on
    every call: 3 microseconds a step, more than running the kernel on both threads of a 2-core machine
    instead of one would cost. Once they are launched, both call numba's own C functions
    (``numba.np.ufunc.parallel._set_num_threads`` and ``_get_num_threads``), which this returns; where
    numba's layout differs, its public functions. A compiled wrapper would set the count as cheaply but
    could not be cached (numba does not cache code that calls its thread functions).
    """
    from numba.np.ufunc import parallel

    numba.get_num_threads()  # launches numba's threads
    setter, getter = getattr(parallel, "_set_num_threads", None), getattr(parallel, "_get_num_threads", None)
    if callable(setter) and callable(getter):
        return setter, getter
    return numba.set_num_threads, numba.get_num_threads


def _by_episode(draws: engine.Draws) -> tuple[list[np.ndarray], list[engine.Draws]]:
    """A block's draws, episode by episode: entry ``j`` is episode ``j``'s as the kernel reads a block of one episode.

    Returns:
        The block's arrays laid out episode first, ``(episodes, seeds, 1, ...)`` (copies, one per field of
        :class:`engine.Draws`), and each episode's draws, whose arrays are ``(seeds, 1, ...)``, contiguous views of
        them (so that writing into the first changes the second).
    """
    masters = [np.ascontiguousarray(np.moveaxis(block, 1, 0)[:, :, None]) for block in draws]
    return masters, list(map(engine.Draws._make, zip(*map(list, masters), strict=True)))


def _compiled(dispatcher: Any, arguments: tuple) -> Callable[..., None]:
    """Call ``dispatcher`` on ``arguments`` (compiling or loading that signature), and return its compiled entry.

    The entry does not check its arguments (an array of another type or layout would be read as if it were
    the compiled one's): only arguments built by :class:`SteppedWorlds` itself reach it. A step calls the kernel
    with arguments of the same types every time (the same lanes, draws of the same
    shape), so it skips numba's dispatch, which types each of the tuples' fields on every call: on 64 worlds of
    ``single`` that costs several times the episode itself (benchmarks/bench_vector_env.py). The entry is
    numba's own compiled function for that signature (``Dispatcher.overloads``).
    """
    dispatcher(*arguments)
    return dispatcher.overloads[tuple(dispatcher.typeof_pyval(a) for a in arguments)].entry_point
