"""What an experiment costs in memory and in stored bytes, and how its work is split into chunks.

An experiment runs as *chunks*: every algorithm over a block of seeds. Lanes do not interact, so
the numbers do not depend on the chunking; what does is memory, which is bounded by the chunk,
not the experiment. :func:`chunk_cost` counts every array a chunk allocates while it runs, as
:mod:`mgrao_core.runner` and :mod:`mgrao_core.oracle` allocate them, and the copies a caller makes
to store the chunk's runs (one serialised copy of every run, as the service's workers do):

* ``state``: every per-lane array, from the same declarations the runner allocates from
  (:mod:`mgrao_core.lanes`): the parents' estimates of children, presence and value profiles, the
  children's allocation, and each algorithm family's state (MG-RAO's PW and trace in lazy form, its
  active rows and counts; the fixed families' allocation);
* ``worlds``: what each seed drew once, and its stacked copies for the kernel;
* ``draws``: one block of per-episode randomness per seed, the per-seed arrays and their stacked
  copies (:data:`mgrao_core.runner.BLOCK_ATOMIC_TASKS` bounds a block);
* ``utilities``: every episode utility of the chunk's runs, and the block's output;
* ``preparation``: what the chunk's algorithm families allocate to prepare it
  (:meth:`Family.preparation_bytes <mgrao_core.algorithms.base.Family.preparation_bytes>`): the
  Monte-Carlo temporaries of the oracle's expected values (one seed at a time,
  :data:`ORACLE_DRAWS` noise values at a time) and its weights;
* ``results``: the final weights copied into each run, and the serialised copy of every run.

What a job *stores* is bounded per run (:func:`stored_weights`): every episode utility, and of the final
weights every child's combined weights and parent-group weights up to :data:`MAX_STORED_COMBINED_VALUES` and
:data:`MAX_STORED_GROUP_VALUES` (beyond, the first children's that fit), with their mean over every child
where a run has more than :data:`MEAN_ABOVE_CHILDREN` children; :func:`result_bytes` counts that.

The process's own baseline (the interpreter, numpy, numba and the compiled kernel, about 150 to
200 MiB) comes on top and is not part of the budget.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Protocol

from mgrao_core.algorithms import Algorithm, family_of
from mgrao_core.algorithms.oracle import ORACLE_BATCH, ORACLE_DRAWS  # noqa: F401  (where oracle.py reads them)
from mgrao_core.lanes import lane_bytes
from mgrao_core.params import SystemParams
from mgrao_core.world import is_dynamic, routing_choices

MAX_CHUNK_BYTES = 2 * 1024**3
"""Default memory budget of one chunk (what :func:`chunk_cost` counts, above the baseline)."""
MAX_RESULT_BYTES = 2 * 1024**3
"""Stored bytes of one experiment's runs: every episode utility and the final weights (:func:`result_bytes`)."""
MAX_STORED_COMBINED_VALUES = 2_000_000
"""Combined weights a run stores, at most (16 MB): every child's up to 100,000 children of 20 types, else the
first children's that fit (every resource's, resource-major)."""
MAX_STORED_GROUP_VALUES = 2_000_000
"""Parent-group weights (PW) a run stores, at most (16 MB): every child's where they fit, else the first
children's that fit (10,000 children x 100 groups x 20 types would be 20,000,000: 160 MB a run)."""
MEAN_ABOVE_CHILDREN = 100
"""A run of more children also stores its weights' mean over every child (combined, and PW where they fit the
bound): what a view of a system too large to show child by child draws (100: every child of the systems that
came before sparse worlds)."""
CHUNK_ATOMIC_TASKS = 50_000_000
"""Atomic tasks per chunk, at most: a few seconds of simulation, so that a job's runs are stored,
and its progress shown, a chunk at a time, and a cluster can share the chunks out."""
BLOCK_ATOMIC_TASKS = 4_000_000
"""Atomic tasks per block: progress is reported and cancellation checked between blocks."""
_F = 8  # bytes of a float64 or an int64


class Experiment(Protocol):
    """What the budget reads of an experiment (:class:`mgrao_core.spec.ExperimentSpec` is one)."""

    @property
    def params(self) -> SystemParams: ...  # noqa: D102
    @property
    def algorithms(self) -> tuple[str, ...]: ...  # noqa: D102
    @property
    def parsed_algorithms(self) -> tuple[Algorithm, ...]: ...  # noqa: D102
    @property
    def seeds(self) -> tuple[int, ...]: ...  # noqa: D102
    @property
    def episodes(self) -> int: ...  # noqa: D102


@dataclass(frozen=True)
class ChunkCost:
    """Bytes a chunk allocates, by kind (see the module docstring)."""

    state: int
    worlds: int
    draws: int
    utilities: int
    preparation: int
    results: int

    @property
    def total(self) -> int:
        """The peak: everything above is alive at once in the worst case."""
        return sum(getattr(self, f.name) for f in fields(self))


def block_episodes(spec: Experiment, n_seeds: int | None = None) -> int:
    """Episodes per block for ``n_seeds`` seeds (all of the spec's by default).

    A block simulates about :data:`BLOCK_ATOMIC_TASKS` atomic tasks.
    """
    p = spec.params
    seeds = len(spec.seeds) if n_seeds is None else n_seeds
    per_episode = seeds * len(spec.algorithms) * p.n_parents * p.types_per_composite
    return int(min(spec.episodes, max(1, BLOCK_ATOMIC_TASKS // per_episode)))


def chunk_cost(spec: Experiment, n_seeds: int) -> ChunkCost:
    """The memory a chunk of ``n_seeds`` seeds of ``spec`` allocates (every algorithm)."""
    p = spec.params
    algorithms = spec.parsed_algorithms
    lanes = n_seeds * len(algorithms)
    children, types, parents, per_composite = p.n_children, p.n_types, p.n_parents, p.types_per_composite
    choices = routing_choices(p)
    state = lane_bytes(p, algorithms, n_seeds)
    per_seed_world = _F * (p.n_composite_types * types + 2 * parents * per_composite + children
                           + 2 * children * types)  # capability, resource per type
    worlds = n_seeds * (per_seed_world + _F * children * types)  # the stacked resources per type
    if p.sparse:  # each seed's links, and their stacked copy
        worlds += n_seeds * 2 * _F * parents * p.children_per_parent
    resources = p.n_resources
    if resources > 1:  # several resources: amounts, needs, each resource per type (and its stacked copy),
        # the one-split resource per type (the oracle's); the kernel's per-lane shares of each task's quality
        worlds += n_seeds * _F * (children * resources + types * resources + 2 * children * resources * types
                                  + children * types)
        worlds += _F * lanes * (parents * per_composite * resources + 2 * resources + 2 * per_composite)
    block = block_episodes(spec, n_seeds)
    volatile = p.leave_probability > 0 or p.join_probability > 0
    per_episode = parents * (
        2 * per_composite  # value noise, and its stacked copy
        + 4  # the order's uniforms, their argsort, its stacked copy and int64 copy
        + 2  # volatility, and its stacked copy
        + (3 * per_composite if volatile and p.rejoin_profile == "new" else 0)  # rejoin profiles (+ gamma draws)
        + (2 * 3 * choices if p.children_offered > 1 else 0)  # routing uniforms, and their stacked copy
        + (4 * per_composite + 1 if is_dynamic(p) else 0)  # event profiles and types, changes, arrivals (+ copies)
    )
    draws = _F * n_seeds * block * per_episode
    utilities = _F * lanes * (spec.episodes + block)
    families = {family_of(a).name: family_of(a) for a in algorithms}
    preparation = sum(f.preparation_bytes(p, n_seeds) for f in families.values())
    weights = sum(children * (a.n_groups + 1) * types for a in algorithms) * n_seeds
    if p.n_resources > 1:  # each resource's final allocation and PW beside the first's
        weights *= 1 + p.n_resources
    results = _F * (2 * weights + lanes * spec.episodes)
    return ChunkCost(state, worlds, draws, utilities, preparation, results)


@dataclass(frozen=True)
class StoredWeights:
    """Which of a run's final weights are stored (see :func:`stored_weights`).

    Attributes:
        children: the run's children.
        combined_children: the first children whose combined weights are stored (every resource's).
        group_children: the first children whose parent-group weights are stored (``children`` when the
            algorithm learns none: nothing is left out).
        means: whether the weights' mean over every child is stored (more than :data:`MEAN_ABOVE_CHILDREN`).
        group_mean: whether that mean includes the PW's (where the algorithm learns them and they fit the bound).
        values: every stored weight: the kept children's and the means.
    """

    children: int
    combined_children: int
    group_children: int
    means: bool
    group_mean: bool
    values: int


def stored_weights(children: int, n_groups: int, n_types: int, n_resources: int = 1) -> StoredWeights:
    """What a run of ``children`` children stores of its final weights, within the bounds above.

    Combined weights ``(n_resources, children, n_types)`` and PW ``(n_resources, children, n_groups, n_types)``:
    each child's while they fit :data:`MAX_STORED_COMBINED_VALUES` and :data:`MAX_STORED_GROUP_VALUES`, the
    first children that fit beyond (none of the PW when one child's alone exceed the bound); and, for more than
    :data:`MEAN_ABOVE_CHILDREN` children, the mean over every child of each (the PW's when they fit the bound).
    """
    per_child = n_resources * n_types
    combined = min(children, MAX_STORED_COMBINED_VALUES // per_child)
    group_values = per_child * n_groups
    grouped = children if n_groups == 0 else min(children, MAX_STORED_GROUP_VALUES // group_values)
    means = children > MEAN_ABOVE_CHILDREN
    group_mean = means and 0 < group_values <= MAX_STORED_GROUP_VALUES
    values = (combined * per_child + grouped * group_values + (per_child if means else 0)
              + (group_values if group_mean else 0))
    return StoredWeights(children, combined, grouped, means, group_mean, values)


def result_bytes(spec: Experiment) -> int:
    """Bytes of every run's stored utilities and final weights (what :data:`MAX_RESULT_BYTES` bounds).

    Every episode utility, and the weights :func:`stored_weights` keeps (a run of several resources keeps
    each resource's, and its first PW beside them where the family keeps one PW).
    """
    p = spec.params
    per_seed = 0
    for a in spec.parsed_algorithms:
        kept = stored_weights(p.n_children, a.n_groups, p.n_types, p.n_resources)
        per_seed += kept.values
        if p.n_resources > 1:  # the first resource's PW beside each resource's, as before bounds existed
            per_seed += stored_weights(p.n_children, a.n_groups, p.n_types).values
    return _F * len(spec.seeds) * (len(spec.algorithms) * spec.episodes + per_seed)


def seeds_per_chunk(spec: Experiment, budget: int = MAX_CHUNK_BYTES) -> int:
    """The most seeds a chunk may hold: within ``budget`` and :data:`CHUNK_ATOMIC_TASKS` (at least 1)."""
    p = spec.params
    per_seed_tasks = len(spec.algorithms) * spec.episodes * p.n_parents * p.types_per_composite
    count = max(1, min(len(spec.seeds), CHUNK_ATOMIC_TASKS // max(1, per_seed_tasks)))
    while count > 1 and chunk_cost(spec, count).total > budget:
        count = max(1, count * budget // chunk_cost(spec, count).total)
    return count


def plan_chunks(spec: Experiment, seeds: tuple[int, ...] | None = None,
                budget: int = MAX_CHUNK_BYTES) -> list[tuple[int, ...]]:
    """``seeds`` (the spec's by default) in chunks of at most :func:`seeds_per_chunk`, in order."""
    seeds = spec.seeds if seeds is None else tuple(seeds)
    size = seeds_per_chunk(spec, budget)
    return [seeds[i : i + size] for i in range(0, len(seeds), size)]
