"""Run an experiment: every (algorithm, seed) lane through the engine, chunk by chunk, block by block.

A *chunk* is every algorithm over a block of seeds (:mod:`mgrao_core.budget` sizes it so that its
memory stays within a budget); a *block* is a run of episodes between two progress reports and
cancellation checks. Lanes never interact, so neither the chunking nor the blocks change a number.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace

import numpy as np

from mgrao_core import engine
from mgrao_core.algorithms import FAMILIES, LEARNERS, family_of
from mgrao_core.algorithms.base import FixedFamily
from mgrao_core.budget import MAX_CHUNK_BYTES, block_episodes, plan_chunks
from mgrao_core.compiling import Compiling, estimate_seconds, parts_of
from mgrao_core.engine import kernel
from mgrao_core.errors import Cancelled, NumericalError
from mgrao_core.lanes import allocate_lanes
from mgrao_core.results import ExperimentResult, Run, TaskCounts
from mgrao_core.spec import ExperimentSpec
from mgrao_core.world import EpisodeDraws, EpisodeStreams, World, draw_links, draw_world

ProgressCallback = Callable[[float], None]
StopCheck = Callable[[], bool]
CompileCallback = Callable[[Compiling], None]


def _build_lanes(spec: ExperimentSpec, worlds: Sequence[World], seeds: Sequence[int],
                 should_stop: StopCheck | None) -> tuple[dict[str, np.ndarray], engine.Lanes, tuple]:
    """Every array of the chunk's lanes (by name), the kernel's lanes, and each learner family's compiled lanes.

    A learner family with no lane in the chunk gets ``None``, so that the kernel is compiled without its
    code (:mod:`mgrao_core.engine.kernel`). The fixed families' allocations are computed here, per seed
    (the oracle's Monte Carlo polls ``should_stop``).
    """
    p = spec.params
    algorithms = spec.parsed_algorithms
    arrays = allocate_lanes(p, algorithms, len(worlds))
    arrays["profiles"][:] = np.stack([worlds[i].profiles for i in arrays["seed_index"]])
    arrays["parent_types"][:] = np.stack([worlds[i].parent_types for i in arrays["seed_index"]])
    for code, family in enumerate(FAMILIES):
        lanes = np.flatnonzero(arrays["kind"] == code)
        if isinstance(family, FixedFamily) and len(lanes):
            weights = [family.fixed_weights(p, world, seed, should_stop)
                       for world, seed in zip(worlds, seeds, strict=True)]
            for lane in lanes:
                arrays["fixed_weights"][lane] = weights[int(arrays["seed_index"][lane])]
    kernel_lanes = engine.Lanes(**{name: arrays[name] for name in engine.Lanes._fields})
    present = {FAMILIES[code].name for code in np.unique(arrays["kind"])}
    return arrays, kernel_lanes, tuple(f.compiled_lanes(arrays, p) if f.name in present else None for f in LEARNERS)


def kernel_worlds(p, worlds: Sequence[World]) -> tuple[engine.Worlds, engine.SeveralResources | None]:
    """The kernel's worlds (each seed's resource per type) and, with several resources, each one's and the needs."""
    single = engine.Worlds(resources=np.ascontiguousarray(np.stack([w.type_resources_single for w in worlds])))
    if p.n_resources == 1:
        return single, None
    return single, engine.SeveralResources(
        per_resource=np.ascontiguousarray(np.stack([w.resource_per_type for w in worlds])),
        needs=np.ascontiguousarray(np.stack([w.needs for w in worlds])),
    )


def kernel_links(p, seeds: Sequence[int]) -> np.ndarray | None:
    """The kernel's links of a sparse world, ``(seeds, n_parents, children_per_parent)``; ``None`` in a complete one."""
    if not p.sparse:
        return None
    return np.ascontiguousarray(np.stack([draw_links(p, seed) for seed in seeds]))


def kernel_failing(p, arrays: dict[str, np.ndarray]) -> engine.Failing | None:
    """The kernel's counts of tasks that fail (the lanes' ``task_counts``), or ``None`` where no task can fail."""
    return engine.Failing(counts=arrays["task_counts"]) if p.tasks_can_fail else None


def _stack(draws: list[EpisodeDraws], name: str) -> np.ndarray:
    return np.ascontiguousarray(np.stack([getattr(d, name) for d in draws]))


def block_draws(draws: list[EpisodeDraws]) -> engine.Draws:
    """Each seed's draws of a block of episodes, stacked as the kernel reads them (first axes: seed, episode)."""
    return engine.Draws(
        noise=_stack(draws, "noise"),
        order=_stack(draws, "order").astype(np.int64),
        volatility=_stack(draws, "volatility"),
        new_profiles=_stack(draws, "new_profiles"),
        routing=_stack(draws, "routing"),
        changes=_stack(draws, "changes"),
        event_profiles=_stack(draws, "event_profiles"),
        event_types=_stack(draws, "event_types"),
        arrives=_stack(draws, "arrives"),
    )


def check_finite(runs: Iterable[Run]) -> None:
    """Raise :class:`NumericalError` naming the first run whose utilities or weights are not all finite."""
    for run in runs:
        for what, values in (("utilities", run.utilities), ("combined weights", run.combined_weights),
                             ("group weights", run.group_weights)):
            if not np.isfinite(values).all():
                raise NumericalError(f"numerical overflow in the {what} of {run.algorithm} seed {run.seed}: "
                                     "a value is not finite; nothing was stored")


def _kernel_types(head: tuple, finish_head: tuple, learners: tuple) -> tuple[tuple, tuple]:
    """The signatures of :func:`engine.run_block` and :func:`engine.finish` on these arguments.

    Asked of the compiled functions themselves (``engine.kernel``'s), so that a caller who wraps ``engine.run_block``
    or ``engine.finish`` to time or watch their calls (benchmarks, tests) wraps the calls alone.
    """
    return (engine.argument_types(kernel.run_block, (*head, *learners)),
            engine.argument_types(kernel.finish, (*finish_head, *learners)))


def _has_code(types: tuple[tuple, tuple]) -> bool:
    return engine.has_code(kernel.run_block, types[0]) and engine.has_code(kernel.finish, types[1])


def ready_kernel(spec: ExperimentSpec, arrays: dict[str, np.ndarray], head: tuple, finish_head: tuple,
                 learners: tuple, on_compile: CompileCallback | None = None) -> tuple:
    """The learners' lanes to run a chunk with, its kernel compiled or loaded (:mod:`mgrao_core.compiling`).

    The chunk's own kernel (its families' lanes, ``None`` for the others) where it is at hand (this process, or
    numba's cache); else the kernel of every family, with the other families' lanes empty, where that one is;
    else the chunk's own is compiled now, ``on_compile`` told before (a :class:`Compiling` without ``seconds``)
    and after (with them). The numbers do not depend on which kernel runs them.

    Args:
        spec: the chunk's experiment.
        arrays: every array of the chunk's lanes, by name.
        head: the kernel's arguments before the learners' lanes (its first block's).
        finish_head: :func:`engine.finish`'s arguments before them.
        learners: each learner family's lanes, ``None`` for a family without lanes in the chunk.
        on_compile: told of a compile, before and after.
    """
    own = _kernel_types(head, finish_head, learners)
    if _has_code(own):
        return learners
    if any(lanes is None for lanes in learners):
        every = tuple(f.compiled_lanes(arrays, spec.params) for f in LEARNERS)
        if _has_code(_kernel_types(head, finish_head, every)):
            return every
    _compile(spec, own, on_compile)
    return learners


def _compile(spec: ExperimentSpec, types: tuple[tuple, tuple], on_compile: CompileCallback | None) -> None:
    """Compile the kernel and its finish for ``types``, ``on_compile`` told before and after."""
    parts = parts_of(spec)
    notice = Compiling(parts, estimate_seconds(parts))
    if on_compile is not None:
        on_compile(notice)
    started = time.perf_counter()
    kernel.run_block.compile(types[0])
    kernel.finish.compile(types[1])
    if on_compile is not None:
        on_compile(replace(notice, seconds=time.perf_counter() - started))


def run_chunk(
    spec: ExperimentSpec,
    seeds: Sequence[int],
    on_progress: ProgressCallback | None = None,
    should_stop: StopCheck | None = None,
    episodes_per_block: int | None = None,
    on_compile: CompileCallback | None = None,
) -> tuple[Run, ...]:
    """Simulate every algorithm of ``spec`` over ``seeds`` (a chunk), in the order algorithms x seeds.

    Args:
        spec: a validated experiment (see :func:`mgrao_core.make_spec`).
        seeds: some of the spec's seeds; a run's numbers do not depend on which others run with it.
        on_progress: called with the fraction of the chunk done (0 < f <= 1) after every block.
        should_stop: polled inside the oracle's estimate (see :mod:`mgrao_core.oracle`) and before every
            block.
        episodes_per_block: override the block size (results do not depend on it).
        on_compile: told when the engine is compiled for the chunk (its combination met for the first time),
            before and after (:class:`mgrao_core.compiling.Compiling`; see :func:`ready_kernel`).

    Raises:
        Cancelled: ``should_stop`` returned True.
        NumericalError: a utility or weight came out infinite or NaN.
    """
    p = spec.params
    seeds = tuple(seeds)
    worlds = [draw_world(p, seed) for seed in seeds]
    arrays, lanes, learners = _build_lanes(spec, worlds, seeds, should_stop)
    world, several = kernel_worlds(p, worlds)
    links = kernel_links(p, seeds)
    environment = engine.environment_of(p)
    streams = [EpisodeStreams(p, seed, world) for seed, world in zip(seeds, worlds, strict=True)]
    utilities = np.zeros((len(lanes.kind), spec.episodes))
    failing = kernel_failing(p, arrays)
    block = episodes_per_block or block_episodes(spec, len(seeds))
    done = 0
    while done < spec.episodes:
        if should_stop is not None and should_stop():
            raise Cancelled(f"stopped after {done} of {spec.episodes} episodes")
        count = min(block, spec.episodes - done)
        out = np.zeros((len(lanes.kind), count))
        head = (lanes, world, several, links, block_draws([s.draw(count) for s in streams]), environment, out, None,
                failing)
        if done == 0:
            learners = ready_kernel(spec, arrays, head, (lanes, several), learners, on_compile)
        engine.run_block(*head, *learners)
        utilities[:, done : done + count] = out
        done += count
        if on_progress is not None:
            on_progress(done / spec.episodes)
    engine.finish(lanes, several, *learners)
    runs = []
    n_algorithms = len(spec.algorithms)
    no_groups = np.zeros((p.n_children, 0, p.n_types))
    for algorithm_index, algorithm in enumerate(spec.parsed_algorithms):
        family = family_of(algorithm)
        for seed_index, seed in enumerate(seeds):
            lane = seed_index * n_algorithms + algorithm_index
            group_weights = family.group_weights(arrays, lane, algorithm)
            membership, every = family.membership(arrays, lane, algorithm, p) or (None, 0)
            resource_group_weights = resource_weights = None
            if p.n_resources > 1:
                resource_weights = lanes.resource_weights[lane].transpose(1, 0, 2).copy()
                if group_weights is not None and family.name == "mgrao":  # learner c * R + r: child c, resource r
                    resource_group_weights = group_weights.reshape(
                        p.n_children, p.n_resources, *group_weights.shape[1:]).transpose(1, 0, 2, 3).copy()
                    group_weights = resource_group_weights[0].copy()
                elif group_weights is not None:  # one PW for every resource
                    group_weights = group_weights[: p.n_children]
                    resource_group_weights = np.stack([group_weights] * p.n_resources)
            runs.append(Run(
                algorithm=algorithm.label,
                seed=seed,
                utilities=utilities[lane],
                group_weights=no_groups.copy() if group_weights is None else group_weights,
                combined_weights=lanes.weights[lane].copy(),
                membership=membership,
                membership_every=every,
                resource_weights=resource_weights,
                resource_group_weights=resource_group_weights,
                tasks=TaskCounts(*map(int, arrays["task_counts"][lane])) if failing is not None else TaskCounts(),
            ))
    check_finite(runs)
    return tuple(runs)


def run_experiment(
    spec: ExperimentSpec,
    on_progress: ProgressCallback | None = None,
    should_stop: StopCheck | None = None,
    episodes_per_block: int | None = None,
    memory_budget: int = MAX_CHUNK_BYTES,
    on_compile: CompileCallback | None = None,
) -> ExperimentResult:
    """Simulate every (algorithm, seed) run of ``spec``, a chunk of seeds at a time.

    Args:
        spec: a validated experiment (see :func:`mgrao_core.make_spec`).
        on_progress: called with the fraction done (0 < f <= 1) after every block.
        should_stop: polled before every block; when it returns True the run stops.
        episodes_per_block: override the block size (results do not depend on it).
        memory_budget: bytes a chunk may allocate (see :mod:`mgrao_core.budget`); the runs
            themselves, every episode utility, accumulate on top.
        on_compile: told when the engine is compiled for the experiment (see :func:`run_chunk`).

    Returns:
        The utilities of every episode of every run and each learner's final weights.

    Raises:
        Cancelled: ``should_stop`` returned True.
        NumericalError: a utility or weight came out infinite or NaN.
    """
    chunks = plan_chunks(spec, budget=memory_budget)
    by_key: dict[tuple[str, int], Run] = {}
    for i, chunk in enumerate(chunks):
        share = len(chunk) / len(spec.seeds)
        start = sum(len(c) for c in chunks[:i]) / len(spec.seeds)
        progress = None if on_progress is None else (lambda f, start=start, share=share: on_progress(start + f * share))
        for run in run_chunk(spec, chunk, progress, should_stop, episodes_per_block, on_compile):
            by_key[(run.algorithm, run.seed)] = run
    return ExperimentResult(spec=spec, runs=tuple(by_key[(a, s)] for a in spec.algorithms for s in spec.seeds))


def compile_for(spec: ExperimentSpec, on_compile: CompileCallback | None = None) -> bool:
    """Compile (or load) the kernel of ``spec``'s own combination without running it; whether it compiled.

    What ``mgrao compile`` does for each experiment of :func:`mgrao_core.compiling.ahead` (one seed of it is
    prepared, the oracle's estimate included, which compiles its own functions the first time). Unlike a run it
    never falls back to the kernel of every family: it makes the combination's own kernel (see
    :func:`ready_kernel`) and stores it in numba's cache.
    """
    p = spec.params
    seed = spec.seeds[0]
    worlds = [draw_world(p, seed)]
    arrays, lanes, learners = _build_lanes(spec, worlds, (seed,), None)
    world, several = kernel_worlds(p, worlds)
    head = (lanes, world, several, kernel_links(p, (seed,)), block_draws([EpisodeStreams(p, seed, worlds[0]).draw(1)]),
            engine.environment_of(p), np.zeros((len(lanes.kind), 1)), None, kernel_failing(p, arrays))
    types = _kernel_types(head, (lanes, several), learners)
    if _has_code(types):
        return False
    _compile(spec, types, on_compile)
    return True
