"""Per-lane arrays, declared by shape: what the runner allocates and the memory budget counts.

A lane is one run (one seed, one algorithm) in the batched kernel. Every array a lane holds is
declared once, as a :class:`StateArray` whose shape is written in named sizes (``"lanes"``,
``"children"``, ``"groups"``, ``"n_types"``, ...): the environment's own arrays in
:mod:`mgrao_core.lanes`, and each algorithm family's in its module (:attr:`Family.state
<mgrao_core.algorithms.base.Family.state>`). :func:`allocate` and :func:`nbytes` read the same
declarations, so the arrays a chunk allocates and the bytes :mod:`mgrao_core.budget` counts for it
cannot drift apart.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np


class System(Protocol):
    """A system's parameters as the algorithms read them: :class:`mgrao_core.params.System`.

    Its fields come from the parameter schema, which lists every registered family's own, so any
    parameter's name is an attribute.
    """

    def __getattr__(self, name: str) -> Any: ...  # noqa: D105

SIZES = ("lanes", "children", "groups", "n_types", "n_parents", "choices", "links", "types_per_composite",
         "tracked_parents", "tracked_children", "snapshots", "learners", "resources", "extra_resources",
         "task_outcomes")
"""The sizes a shape may name: the chunk's lanes, the system's children, the most parent groups of
the chunk's algorithms (at least 1), atomic types, parents, a parent's child choices per composite
(:func:`mgrao_core.world.routing_choices`), the children a parent chooses among (``links``: every child, or
``children_per_parent`` in a sparse world) and atomic types per composite; and two a family asks for
(:meth:`Family.sizes <mgrao_core.algorithms.base.Family.sizes>`, the largest over the chunk's
algorithms, else 0): parents and children a learner keeps statistics or counters of, and records of a
bounded history. So a chunk that runs no such family holds none of those arrays. With several resources
(docs/model.md, "Several resources"): ``learners``, a child's learners, one per resource (``n_children *
n_resources``: MG-RAO keeps a PW per resource), ``resources`` (``n_resources``) and ``extra_resources``
(``n_resources`` when above 1, else 0: what one resource needs no array of). Where tasks can fail
(``task_need > 0``), ``task_outcomes``: 3 (allocated, failed, completed through a neighbour), else 0."""
FAMILY_SIZES = ("tracked_parents", "tracked_children", "snapshots")
"""The sizes of :data:`SIZES` a family's :meth:`~mgrao_core.algorithms.base.Family.sizes` sets (else 0)."""


@dataclass(frozen=True)
class StateArray:
    """One per-lane array.

    Attributes:
        name: the array's name (a field of the kernel's lanes, or of a family's compiled lanes).
        shape: named sizes (:data:`SIZES`), the first ``"lanes"``.
        dtype: ``"float64"``, ``"int64"`` or ``"bool"``.
        fill: the initial value of every element (a number, or ``"uniform"``: ``1 / n_types``).
        help: what it holds, for people.
    """

    name: str
    shape: tuple[str, ...]
    dtype: str = "float64"
    fill: float | bool | str = 0.0
    help: str = ""

    def __post_init__(self) -> None:
        unknown = [s for s in self.shape if s not in SIZES]
        if unknown or not self.shape or self.shape[0] != "lanes":
            raise ValueError(f"{self.name}: a shape starts with 'lanes' and names sizes of {SIZES} (got {self.shape})")

    def dims(self, sizes: Mapping[str, int]) -> tuple[int, ...]:
        """The array's shape for ``sizes``."""
        return tuple(sizes[s] for s in self.shape)

    def nbytes(self, sizes: Mapping[str, int]) -> int:
        """Bytes of the array for ``sizes``."""
        return math.prod(self.dims(sizes)) * np.dtype(self.dtype).itemsize

    def allocate(self, sizes: Mapping[str, int]) -> np.ndarray:
        """A new array of the declared shape, type and initial value."""
        if self.fill == "uniform":
            return np.full(self.dims(sizes), 1.0 / sizes["n_types"], dtype=self.dtype)
        if self.fill == 0:
            return np.zeros(self.dims(sizes), dtype=self.dtype)
        return np.full(self.dims(sizes), self.fill, dtype=self.dtype)


def routing_choices(params: System) -> int:
    """Child choices a parent makes per composite task: 1 per composite, or one per atomic task."""
    return 1 if params.routing == "per-composite" else params.types_per_composite


def sizes_of(params: System, lanes: int, groups: int, family_sizes: Mapping[str, int] | None = None) -> dict[str, int]:
    """The named sizes (:data:`SIZES`) of ``lanes`` lanes of a system whose algorithms have at most ``groups``.

    ``family_sizes`` gives those of :data:`FAMILY_SIZES` the chunk's algorithms ask for (the others are 0).
    """
    resources = getattr(params, "n_resources", 1)
    return {"lanes": lanes, "children": params.n_children, "groups": max(groups, 1), "n_types": params.n_types,
            "n_parents": params.n_parents, "choices": routing_choices(params), "links": params.children_offered,
            "types_per_composite": params.types_per_composite, "learners": params.n_children * resources,
            "resources": resources, "extra_resources": resources if resources > 1 else 0,
            "task_outcomes": 3 if params.tasks_can_fail else 0} | {
                name: 0 for name in FAMILY_SIZES} | dict(family_sizes or {})


def nbytes(arrays: Iterable[StateArray], sizes: Mapping[str, int]) -> int:
    """Bytes of every array of ``arrays`` for ``sizes``."""
    return sum(a.nbytes(sizes) for a in arrays)


def allocate(arrays: Iterable[StateArray], sizes: Mapping[str, int]) -> dict[str, np.ndarray]:
    """Every array of ``arrays``, by name, allocated for ``sizes``."""
    return {a.name: a.allocate(sizes) for a in arrays}
