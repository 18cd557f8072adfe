"""Every array a chunk's lanes hold, declared: the environment's own, and each algorithm family's.

A chunk runs every algorithm over a block of seeds, one *lane* per (seed, algorithm), seed-major.
The runner allocates a chunk's arrays with :func:`allocate_lanes` and the memory budget counts them
with :func:`lane_bytes`, both from the same declarations (:class:`~mgrao_core.algorithms.state.StateArray`):
:data:`ENVIRONMENT` here, and :attr:`Family.state <mgrao_core.algorithms.base.Family.state>` of
every registered family, so that what is allocated and what is counted cannot drift apart.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from mgrao_core.algorithms import FAMILIES, FAMILIES_BY_NAME, KINDS, Algorithm, task_share
from mgrao_core.algorithms.state import StateArray, allocate, nbytes, sizes_of

if TYPE_CHECKING:
    from mgrao_core.params import SystemParams

ENVIRONMENT: tuple[StateArray, ...] = (
    StateArray("seed_index", ("lanes",), "int64", help="the lane's seed, an index into the chunk's seeds"),
    StateArray("kind", ("lanes",), "int64", help="the code of the lane's family (mgrao_core.algorithms.KINDS)"),
    StateArray("groups", ("lanes",), "int64", help="parent groups per child of the lane's algorithm (0: none)"),
    StateArray("task_share", ("lanes", "children"), fill=1.0,
               help="the share of each child's resources its tasks get, what learning leaves (learning_cost)"),
    StateArray("weights", ("lanes", "children", "n_types"), fill="uniform",
               help="each child's allocation in the current episode"),
    StateArray("resource_weights", ("lanes", "children", "extra_resources", "n_types"), fill="uniform",
               help="with several resources, each child's allocation of each resource in the current episode"),
    StateArray("estimates", ("lanes", "n_parents", "choices", "links"),
               help="each parent's running mean of what each child it chooses among (its links) gave back"),
    StateArray("tries", ("lanes", "n_parents", "choices", "links"), "int64",
               help="how often each parent tried each child it chooses among"),
    StateArray("active", ("lanes", "n_parents"), "bool", fill=True, help="which parents are present"),
    StateArray("profiles", ("lanes", "n_parents", "types_per_composite"), help="each parent's value profile"),
    StateArray("parent_types", ("lanes", "n_parents", "types_per_composite"), "int64",
               help="the atomic types of each parent's composite type (scheduled events and unpredictable parents "
                    "change them)"),
    StateArray("task_counts", ("lanes", "task_outcomes"), "int64",
               help="where tasks can fail (task_need): atomic tasks allocated, failed, completed through a neighbour"),
)
"""What every lane holds whatever its algorithm: the parents' side of the system and the children's
allocation in force."""


def declarations() -> tuple[StateArray, ...]:
    """Every per-lane array: :data:`ENVIRONMENT`, then each family's in registry order, once per name.

    Raises:
        ValueError: two declarations of one name differ.
    """
    by_name: dict[str, StateArray] = {}
    for array in ENVIRONMENT + tuple(a for f in FAMILIES for a in f.state):
        if by_name.setdefault(array.name, array) != array:
            raise ValueError(f"two different declarations of the lane array {array.name!r}")
    return tuple(by_name.values())


def chunk_sizes(params: SystemParams, algorithms: Sequence[Algorithm], n_seeds: int) -> dict[str, int]:
    """The named sizes of a chunk of ``n_seeds`` seeds running every one of ``algorithms``.

    A size a family asks for (:meth:`Family.sizes <mgrao_core.algorithms.base.Family.sizes>`) is the
    largest any of ``algorithms`` asks for, and 0 when none does (so other chunks hold none of it).
    """
    wanted: dict[str, int] = {}
    for algorithm in algorithms:
        for name, size in FAMILIES_BY_NAME[algorithm.kind].sizes(algorithm, params).items():
            wanted[name] = max(wanted.get(name, 0), size)
    return sizes_of(params, n_seeds * len(algorithms), max([a.n_groups for a in algorithms] + [1]), wanted)


def lane_bytes(params: SystemParams, algorithms: Sequence[Algorithm], n_seeds: int) -> int:
    """Bytes of every per-lane array of a chunk of ``n_seeds`` seeds (what :func:`allocate_lanes` allocates)."""
    return nbytes(declarations(), chunk_sizes(params, algorithms, n_seeds))


def allocate_lanes(params: SystemParams, algorithms: Sequence[Algorithm], n_seeds: int) -> dict[str, np.ndarray]:
    """Every per-lane array of a chunk, by name, with the lanes' seeds, families, groups and task shares set.

    Lanes are seed-major (lane ``seed * len(algorithms) + algorithm``): the kernel's parallel loop
    hands each thread a contiguous range of lanes, and interleaving the algorithms gives every thread
    a share of the costly many-group lanes. Each family then sets its own lanes' initial state
    (:meth:`Family.initialise <mgrao_core.algorithms.base.Family.initialise>`); the caller fills
    ``profiles``, ``parent_types`` and the fixed families' ``fixed_weights``.
    """
    arrays = allocate(declarations(), chunk_sizes(params, algorithms, n_seeds))
    arrays["seed_index"][:] = np.repeat(np.arange(n_seeds), len(algorithms))
    arrays["kind"][:] = np.tile([KINDS[a.kind] for a in algorithms], n_seeds)
    arrays["groups"][:] = np.tile([a.n_groups for a in algorithms], n_seeds)
    arrays["task_share"][:] = np.tile([task_share(a, params) for a in algorithms], n_seeds)[:, None]
    arrays["estimates"][:] = params.initial_estimate
    for code, family in enumerate(FAMILIES):
        lanes = np.flatnonzero(arrays["kind"] == code)
        if len(lanes):
            family.initialise(arrays, lanes, params)
    return arrays
