"""Run an experiment: every (algorithm, seed) lane through the engine, chunk by chunk, block by block.

A *chunk* is every algorithm over a block of seeds (:mod:`mgrao_core.budget` sizes it so that its
memory stays within a budget); a *block* is a run of episodes between two progress reports and
cancellation checks. Lanes never interact, so neither the chunking nor the blocks change a number.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence

import numpy as np

from mgrao_core import engine
from mgrao_core.budget import MAX_CHUNK_BYTES, block_episodes, plan_chunks
from mgrao_core.errors import Cancelled, NumericalError
from mgrao_core.oracle import oracle_weights
from mgrao_core.results import ExperimentResult, Run
from mgrao_core.spec import ExperimentSpec
from mgrao_core.world import EpisodeDraws, EpisodeStreams, World, draw_world, routing_choices

_KINDS = {"uniform": engine.KIND_UNIFORM, "oracle": engine.KIND_ORACLE, "mgrao": engine.KIND_MGRAO}

ProgressCallback = Callable[[float], None]
StopCheck = Callable[[], bool]


def _build_lanes(spec: ExperimentSpec, worlds: Sequence[World], oracle: Sequence[np.ndarray],
                 learning: engine.Learning) -> engine.Lanes:
    p = spec.params
    algorithms = spec.parsed_algorithms
    n_lanes = len(algorithms) * len(worlds)
    max_groups = max([a.n_groups for a in algorithms] + [1])
    shape = (n_lanes, p.n_children)
    # Seed-major lanes: the kernel's parallel loop hands each thread a contiguous range of lanes, and
    # interleaving the algorithms gives every thread a share of the costly many-group lanes.
    seed_index = np.repeat(np.arange(len(worlds)), len(algorithms))
    kind = np.tile([_KINDS[a.kind] for a in algorithms], len(worlds)).astype(np.int64)
    groups = np.tile([a.n_groups for a in algorithms], len(worlds)).astype(np.int64)
    fixed = np.full(shape + (p.n_types,), 1.0 / p.n_types)
    for lane in np.flatnonzero(kind == engine.KIND_ORACLE):
        fixed[lane] = oracle[int(seed_index[lane])]
    estimates_shape = (n_lanes, p.n_parents, routing_choices(p), p.n_children)
    rows, slot, n_rows = engine.initial_rows(groups, p.n_children, max_groups, learning.min_bounded_groups)
    return engine.Lanes(
        seed_index=seed_index.astype(np.int64),
        kind=kind,
        groups=groups,
        fixed_weights=fixed,
        Y=np.full(shape + (max_groups, p.n_types), 1.0 / p.n_types),
        F=np.zeros(shape + (max_groups, p.n_types)),
        H=np.zeros(shape + (max_groups,)),
        cs=np.ones(shape + (max_groups,)),
        G=np.zeros(shape + (max_groups,)),
        k_since_rebase=np.zeros(shape, dtype=np.int64),
        rows=rows,
        slot=slot,
        n_rows=n_rows,
        counts=np.zeros(shape + (max_groups,)),
        weights=fixed.copy(),
        estimates=np.full(estimates_shape, p.initial_estimate),
        tries=np.zeros(estimates_shape, dtype=np.int64),
        active=np.ones((n_lanes, p.n_parents), dtype=np.bool_),
        profiles=np.stack([worlds[i].profiles for i in seed_index]),
    )


def _stack(draws: list[EpisodeDraws], name: str) -> np.ndarray:
    return np.ascontiguousarray(np.stack([getattr(d, name) for d in draws]))


def _block_draws(draws: list[EpisodeDraws]) -> engine.Draws:
    return engine.Draws(
        noise=_stack(draws, "noise"),
        order=_stack(draws, "order").astype(np.int64),
        volatility=_stack(draws, "volatility"),
        new_profiles=_stack(draws, "new_profiles"),
        routing=_stack(draws, "routing"),
    )


def check_finite(runs: Iterable[Run]) -> None:
    """Raise :class:`NumericalError` naming the first run whose utilities or weights are not all finite."""
    for run in runs:
        for what, values in (("utilities", run.utilities), ("combined weights", run.combined_weights),
                             ("group weights", run.group_weights)):
            if not np.isfinite(values).all():
                raise NumericalError(f"numerical overflow in the {what} of {run.algorithm} seed {run.seed}: "
                                     "a value is not finite; nothing was stored")


def run_chunk(
    spec: ExperimentSpec,
    seeds: Sequence[int],
    on_progress: ProgressCallback | None = None,
    should_stop: StopCheck | None = None,
    episodes_per_block: int | None = None,
) -> tuple[Run, ...]:
    """Simulate every algorithm of ``spec`` over ``seeds`` (a chunk), in the order algorithms x seeds.

    Args:
        spec: a validated experiment (see :func:`mgrao_core.make_spec`).
        seeds: some of the spec's seeds; a run's numbers do not depend on which others run with it.
        on_progress: called with the fraction of the chunk done (0 < f <= 1) after every block.
        should_stop: polled inside the oracle's estimate (see :mod:`mgrao_core.oracle`) and before every
            block.
        episodes_per_block: override the block size (results do not depend on it).

    Raises:
        Cancelled: ``should_stop`` returned True.
        NumericalError: a utility or weight came out infinite or NaN.
    """
    p = spec.params
    seeds = tuple(seeds)
    worlds = [draw_world(p, seed) for seed in seeds]
    oracle = []
    if "oracle" in spec.algorithms:
        for world, seed in zip(worlds, seeds, strict=True):
            oracle.append(oracle_weights(p, world, seed, should_stop=should_stop))
    learning = engine.learning_of(p)
    lanes = _build_lanes(spec, worlds, oracle, learning)
    world = engine.Worlds(
        parent_types=np.ascontiguousarray(np.stack([w.parent_types for w in worlds]).astype(np.int64)),
        resources=np.ascontiguousarray(np.stack([w.resources for w in worlds])),
    )
    environment = engine.environment_of(p)
    streams = [EpisodeStreams(p, seed) for seed in seeds]
    utilities = np.zeros((len(lanes.kind), spec.episodes))
    block = episodes_per_block or block_episodes(spec, len(seeds))
    done = 0
    while done < spec.episodes:
        if should_stop is not None and should_stop():
            raise Cancelled(f"stopped after {done} of {spec.episodes} episodes")
        count = min(block, spec.episodes - done)
        out = np.zeros((len(lanes.kind), count))
        engine.run_block(lanes, world, _block_draws([s.draw(count) for s in streams]), environment, learning, out)
        utilities[:, done : done + count] = out
        done += count
        if on_progress is not None:
            on_progress(done / spec.episodes)
    engine.finish(lanes, learning)
    runs = []
    n_algorithms = len(spec.algorithms)
    for algorithm_index, algorithm in enumerate(spec.algorithms):
        for seed_index, seed in enumerate(seeds):
            lane = seed_index * n_algorithms + algorithm_index
            m = int(lanes.groups[lane])
            runs.append(Run(
                algorithm=algorithm,
                seed=seed,
                utilities=utilities[lane],
                group_weights=lanes.Y[lane, :, :m].copy(),
                combined_weights=lanes.weights[lane].copy(),
            ))
    check_finite(runs)
    return tuple(runs)


def run_experiment(
    spec: ExperimentSpec,
    on_progress: ProgressCallback | None = None,
    should_stop: StopCheck | None = None,
    episodes_per_block: int | None = None,
    memory_budget: int = MAX_CHUNK_BYTES,
) -> ExperimentResult:
    """Simulate every (algorithm, seed) run of ``spec``, a chunk of seeds at a time.

    Args:
        spec: a validated experiment (see :func:`mgrao_core.make_spec`).
        on_progress: called with the fraction done (0 < f <= 1) after every block.
        should_stop: polled before every block; when it returns True the run stops.
        episodes_per_block: override the block size (results do not depend on it).
        memory_budget: bytes a chunk may allocate (see :mod:`mgrao_core.budget`); the runs
            themselves, every episode utility, accumulate on top.

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
        for run in run_chunk(spec, chunk, progress, should_stop, episodes_per_block):
            by_key[(run.algorithm, run.seed)] = run
    return ExperimentResult(spec=spec, runs=tuple(by_key[(a, s)] for a in spec.algorithms for s in spec.seeds))
