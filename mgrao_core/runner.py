"""Run an experiment: every (algorithm, seed) lane through the engine, block by block."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mgrao_core import engine
from mgrao_core.errors import Cancelled
from mgrao_core.oracle import oracle_weights
from mgrao_core.results import ExperimentResult, Run
from mgrao_core.spec import ExperimentSpec
from mgrao_core.world import EpisodeDraws, EpisodeStreams, draw_world

BLOCK_ATOMIC_TASKS = 4_000_000
"""Atomic tasks per block: progress is reported and cancellation checked between blocks."""
_KINDS = {"uniform": engine.KIND_UNIFORM, "oracle": engine.KIND_ORACLE, "mgrao": engine.KIND_MGRAO}

ProgressCallback = Callable[[float], None]
StopCheck = Callable[[], bool]


@dataclass
class _Lanes:
    """Per-lane static inputs and mutable learner state, laid out for the engine."""

    seed_index: np.ndarray
    kind: np.ndarray
    groups: np.ndarray
    fixed_weights: np.ndarray
    Y: np.ndarray
    F: np.ndarray
    H: np.ndarray
    cs: np.ndarray
    G: np.ndarray
    k_since_rebase: np.ndarray
    counts: np.ndarray
    weights: np.ndarray
    estimates: np.ndarray
    tries: np.ndarray
    active: np.ndarray
    profiles: np.ndarray


def _build_lanes(spec: ExperimentSpec, worlds: list, oracle: dict[int, np.ndarray]) -> _Lanes:
    p = spec.params
    algorithms = spec.parsed_algorithms
    n_lanes = len(algorithms) * len(spec.seeds)
    max_groups = max([a.n_groups for a in algorithms] + [1])
    shape = (n_lanes, p.n_children)
    seed_index = np.tile(np.arange(len(spec.seeds)), len(algorithms))
    kind = np.repeat([_KINDS[a.kind] for a in algorithms], len(spec.seeds)).astype(np.int64)
    groups = np.repeat([a.n_groups for a in algorithms], len(spec.seeds)).astype(np.int64)
    fixed = np.full(shape + (p.n_types,), 1.0 / p.n_types)
    for lane in np.flatnonzero(kind == engine.KIND_ORACLE):
        fixed[lane] = oracle[int(seed_index[lane])]
    return _Lanes(
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
        counts=np.zeros(shape + (max_groups,)),
        weights=fixed.copy(),
        estimates=np.full((n_lanes, p.n_parents, p.types_per_composite, p.n_children), p.initial_estimate),
        tries=np.zeros((n_lanes, p.n_parents, p.types_per_composite, p.n_children), dtype=np.int64),
        active=np.ones((n_lanes, p.n_parents), dtype=np.bool_),
        profiles=np.stack([worlds[i].profiles for i in seed_index]),
    )


def _stack(draws: list[EpisodeDraws], name: str) -> np.ndarray:
    return np.ascontiguousarray(np.stack([getattr(d, name) for d in draws]))


def block_episodes(spec: ExperimentSpec) -> int:
    """Episodes per block, so that a block simulates about :data:`BLOCK_ATOMIC_TASKS` tasks."""
    p = spec.params
    per_episode = len(spec.seeds) * len(spec.algorithms) * p.n_parents * p.types_per_composite
    return int(min(spec.episodes, max(1, BLOCK_ATOMIC_TASKS // per_episode)))


def run_experiment(
    spec: ExperimentSpec,
    on_progress: ProgressCallback | None = None,
    should_stop: StopCheck | None = None,
    episodes_per_block: int | None = None,
) -> ExperimentResult:
    """Simulate every (algorithm, seed) run of ``spec``.

    Args:
        spec: a validated experiment (see :func:`mgrao_core.make_spec`).
        on_progress: called with the fraction done (0 < f <= 1) after every block.
        should_stop: polled before every block; when it returns True the run stops.
        episodes_per_block: override the block size (results do not depend on it).

    Returns:
        The utilities of every episode of every run and each learner's final weights.

    Raises:
        Cancelled: ``should_stop`` returned True.
    """
    p = spec.params
    worlds = [draw_world(p, seed) for seed in spec.seeds]
    oracle = {
        i: oracle_weights(p, worlds[i], seed)
        for i, seed in enumerate(spec.seeds)
        if "oracle" in spec.algorithms
    }
    lanes = _build_lanes(spec, worlds, oracle)
    parent_types = np.ascontiguousarray(np.stack([w.parent_types for w in worlds]).astype(np.int64))
    streams = [EpisodeStreams(p, seed) for seed in spec.seeds]
    gamma_pow = p.trace_decay ** np.arange(engine.rebase_interval(p.trace_decay) + 1, dtype=float)
    utilities = np.zeros((len(lanes.kind), spec.episodes))
    block = episodes_per_block or block_episodes(spec)
    done = 0
    while done < spec.episodes:
        if should_stop is not None and should_stop():
            raise Cancelled(f"stopped after {done} of {spec.episodes} episodes")
        count = min(block, spec.episodes - done)
        draws = [s.draw(count) for s in streams]
        out = np.zeros((len(lanes.kind), count))
        engine.run_block(
            lanes.seed_index, lanes.kind, lanes.groups, lanes.fixed_weights,
            parent_types,
            lanes.Y, lanes.F, lanes.H, lanes.cs, lanes.G, lanes.k_since_rebase, lanes.counts,
            lanes.weights, lanes.estimates, lanes.tries, lanes.active, lanes.profiles,
            _stack(draws, "noise"), _stack(draws, "order").astype(np.int64), _stack(draws, "volatility"),
            _stack(draws, "new_profiles"), _stack(draws, "routing"),
            p.n_types, p.quality_at_uniform, p.quality_floor, p.value_noise, p.learning_rate,
            p.effective_temperature, p.epsilon, p.boltzmann_temperature, p.tie_break == "first",
            p.leave_probability, p.join_probability, p.rejoin_profile == "new",
            gamma_pow, 1.0 / gamma_pow,
            out,
        )
        utilities[:, done : done + count] = out
        done += count
        if on_progress is not None:
            on_progress(done / spec.episodes)
    engine.finish(
        lanes.kind, lanes.groups, lanes.Y, lanes.F, lanes.H, lanes.cs, lanes.G, lanes.k_since_rebase,
        lanes.counts, lanes.weights, p.effective_temperature, gamma_pow,
    )
    runs = []
    for lane, (algorithm, seed) in enumerate(
        (a, s) for a in spec.algorithms for s in spec.seeds
    ):
        m = int(lanes.groups[lane])
        runs.append(
            Run(
                algorithm=algorithm,
                seed=seed,
                utilities=utilities[lane],
                group_weights=lanes.Y[lane, :, :m].copy(),
                combined_weights=lanes.weights[lane].copy(),
            )
        )
    return ExperimentResult(spec=spec, runs=tuple(runs))
