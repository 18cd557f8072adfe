"""Algorithms: one module per family, registered here; labels, parsing and the registry clients read.

The families, in the order an unknown label's error lists them:

* :mod:`~mgrao_core.algorithms.uniform`: the uniform allocation (the baseline);
* :mod:`~mgrao_core.algorithms.oracle`: the best fixed allocation (an upper bound);
* :mod:`~mgrao_core.algorithms.mgrao`: MG-RAO, ``mgrao-x:y`` and ``mgrao-max`` (paper table
  "Summary of algorithm labels"; y > 1: children that share their model);
* :mod:`~mgrao_core.algorithms.adaptive`: MG-RAO with adaptive parent groups, ``mgrao-adaptive:x``
  (the paper's future work);
* :mod:`~mgrao_core.algorithms.independent_q`: ``independent-q``, a standard independent learner;
* :mod:`~mgrao_core.algorithms.bandit`: ``bandit``, a gradient bandit over atomic types;
* :mod:`~mgrao_core.algorithms.balance`: MG-RAO that chooses its number of parent groups as it learns,
  ``mgrao-balance[:M]`` (the paper's future work on the cost of learning).

:func:`parse_algorithm` turns a label into an :class:`Algorithm` by asking each family in turn;
:func:`describe_label` and :func:`registry` are what the API's ``GET /api/algorithms`` and
``mgrao algorithms`` serve, so that no client parses labels or lists algorithms of its own.
docs/algorithms.md shows how to add a family.
"""

from __future__ import annotations

from typing import Any

from mgrao_core import equations
from mgrao_core.algorithms import adaptive, balance, bandit, independent_q, mgrao, oracle, uniform
from mgrao_core.algorithms.base import PALETTE_SLOTS, Algorithm, Family
from mgrao_core.algorithms.mgrao import MAX_LABEL as MGRAO_MAX
from mgrao_core.algorithms.mgrao import divisors, parent_groups
from mgrao_core.algorithms.oracle import LABEL as ORACLE
from mgrao_core.algorithms.state import System
from mgrao_core.algorithms.uniform import LABEL as UNIFORM
from mgrao_core.errors import ConfigError

FAMILIES: tuple[Family, ...] = (uniform.FAMILY, oracle.FAMILY, mgrao.FAMILY, adaptive.FAMILY, independent_q.FAMILY,
                                bandit.FAMILY, balance.FAMILY)
"""Every registered family. A new family is a module with a ``FAMILY`` and a line here."""
FAMILIES_BY_NAME: dict[str, Family] = {f.name: f for f in FAMILIES}
KINDS: dict[str, int] = {f.name: code for code, f in enumerate(FAMILIES)}
"""Each family's code: its place in :data:`FAMILIES`, what the kernel dispatches on."""
LEARNERS: tuple[Family, ...] = tuple(f for f in FAMILIES if f.learns)
"""The families with compiled steps, in registry order: the kernel takes their lanes in this order."""


def family_of(algorithm: Algorithm) -> Family:
    """The family a parsed algorithm belongs to."""
    return FAMILIES_BY_NAME[algorithm.kind]


def parse_algorithm(label: Any, n_parents: int | None, field: str = "algorithm",
                    n_children: int | None = None) -> Algorithm:
    """Turn a label into an :class:`Algorithm` for a system with ``n_parents`` parents and ``n_children`` children.

    Labels are read without case or surrounding spaces (and ratios without leading zeros): the
    returned ``label`` is the canonical spelling (``" MGRAO-05:1"`` is ``"mgrao-5:1"``). With
    ``n_parents`` None only the grammar is checked (a caller without a system, such as a sort key); with
    ``n_children`` None nothing is checked against the children (MG-RAO's y of ``mgrao-x:y``).

    Raises:
        ConfigError: naming ``field``: an unknown label (the message says how labels are written),
            or a label its family does not allow in this system.
    """
    text = label.strip().lower() if isinstance(label, str) else None
    if text is not None:
        for family in FAMILIES:
            algorithm = family.parse(text, n_parents, field)
            if algorithm is not None:
                if n_children is not None:
                    family.check_children(algorithm, n_children, field)
                return algorithm
    raise ConfigError(field, f"unknown algorithm {label!r}: use {', '.join(f.hint(n_parents) for f in FAMILIES)}")


def learned_by_max(params: System) -> int:
    """What one child of ``mgrao-max`` keeps (:meth:`Family.learned_numbers`): the yardstick of ``learning_cost``."""
    return mgrao.FAMILY.learned_numbers(Algorithm(MGRAO_MAX, mgrao.FAMILY.name, params.n_parents), params)


def task_share(algorithm: Algorithm, params: System, groups: int | None = None) -> float:
    """The share of each child's resources its tasks get under ``learning_cost`` (:func:`.equations.task_share`).

    What ``algorithm``'s children learn (:meth:`Family.learned_numbers`; with ``groups``, what a child with that
    many groups keeps, :meth:`Family.learned_with`: ``mgrao-balance``'s changes as it runs) priced against
    ``mgrao-max``'s; 1 without a cost (the paper's experiments: nothing computed, every family's numbers unchanged).
    What learning takes is the rest, ``1 - task_share``.

    Raises:
        ConfigError: naming ``learning_cost``, for a learner that does not declare what it learns.
    """
    cost = getattr(params, "learning_cost", 0.0)
    if not cost:
        return 1.0
    family = family_of(algorithm)
    try:
        learned = (family.learned_numbers(algorithm, params) if groups is None
                   else family.learned_with(algorithm, params, groups))
    except NotImplementedError as error:
        raise ConfigError("learning_cost", str(error)) from None
    return equations.task_share(cost, learned, learned_by_max(params))


def groups_at_end(history: Any) -> Any:
    """Each child's number of parent groups in its last recorded membership.

    Args:
        history: a run's recorded memberships ``(children, records, n_parents)`` (:meth:`Family.membership`),
            each parent's group ``0 .. m - 1`` in each record.

    Returns:
        ``(children,)`` the groups of each child's last record (every group holds a parent: ``m <= n_parents``).
    """
    return history[:, -1, :].max(axis=1) + 1


def parse_algorithms(labels: list[str] | tuple[str, ...], n_parents: int | None,
                     n_children: int | None = None) -> tuple[Algorithm, ...]:
    """Parse a non-empty list of distinct labels (field names ``algorithms[i]`` in errors).

    Two spellings of one algorithm (``mgrao-1:1`` and ``mgrao-01:1``) are a repeat. ``n_parents`` and
    ``n_children`` as :func:`parse_algorithm`'s.
    """
    if not labels:
        raise ConfigError("algorithms", "must name at least one algorithm")
    parsed = []
    seen: dict[str, int] = {}
    for i, label in enumerate(labels):
        algorithm = parse_algorithm(label, n_parents, f"algorithms[{i}]", n_children)
        parsed.append(algorithm)
        if algorithm.label in seen:
            raise ConfigError(
                f"algorithms[{i}]",
                f"repeats algorithms[{seen[algorithm.label]}] ({labels[i]!r} is {algorithm.label!r})",
            )
        seen[algorithm.label] = i
    return tuple(parsed)


def valid_labels(labels: list[str] | tuple[str, ...], n_parents: int | None,
                 n_children: int | None = None) -> tuple[str, ...]:
    """The labels valid in a system of ``n_parents`` parents and ``n_children`` children, in their order.

    ``mgrao-25:1`` leaves a 30-parent one, ``mgrao-5:2`` a 3-child one. A preset's configurations are its default;
    where overrides change its parents or children, these are what is left of them.
    """
    valid = []
    for label in labels:
        try:
            parse_algorithm(label, n_parents, n_children=n_children)
        except ConfigError:
            continue
        valid.append(label)
    return tuple(valid)


def sort_key(label: str) -> tuple[int, int, str]:
    """Where a configuration comes in views: uniform, then x:1 by x, then max, then the oracle.

    A label no family recognises comes last, by its spelling.
    """
    try:
        algorithm = parse_algorithm(label, None)
    except ConfigError:
        return (max(f.rank for f in FAMILIES) + 1, 0, str(label))
    return (*family_of(algorithm).sort_key(algorithm), algorithm.label)


def describe_label(label: Any, params: System | None = None, field: str = "label") -> dict[str, Any]:
    """One label, canonical and described for a system (``params``; None: the grammar alone).

    What ``GET /api/algorithms?label=`` answers.

    Raises:
        ConfigError: as :func:`parse_algorithm`.
    """
    algorithm = parse_algorithm(label, None if params is None else params.n_parents, field,
                                None if params is None else params.n_children)
    family = family_of(algorithm)
    return {"label": algorithm.label, "family": family.name, "title": family.title,
            "groups": algorithm.n_groups or None, "team_size": algorithm.team_size if algorithm.n_groups else None,
            "description": family.description, "colour_key": family.colour_key(algorithm),
            "sort_key": list(family.sort_key(algorithm)),
            "memory_per_child": None if params is None else family.memory_per_child(algorithm, params)}


def registry(params: System | None = None) -> list[dict[str, Any]]:
    """Every family for clients: name, description, label forms and examples valid for a system.

    ``params`` None describes the grammar alone (no system chosen yet). ``memory_per_child`` maps each
    example to the bytes of one child's state in the system (None without a system).
    """
    n_parents = None if params is None else params.n_parents

    def memory(family: Family) -> dict[str, int] | None:
        if params is None:
            return None
        return {label: family.memory_per_child(parse_algorithm(label, n_parents), params)
                for label in family.examples(n_parents)}

    return [{"name": f.name, "title": f.title, "description": f.description, "rank": f.rank,
             "parameters": [p.name for p in f.parameters], "forms": f.system_forms(params),
             "examples": f.examples(n_parents), "memory_per_child": memory(f)} for f in FAMILIES]


__all__ = [
    "FAMILIES",
    "FAMILIES_BY_NAME",
    "KINDS",
    "LEARNERS",
    "MGRAO_MAX",
    "ORACLE",
    "PALETTE_SLOTS",
    "UNIFORM",
    "Algorithm",
    "Family",
    "describe_label",
    "divisors",
    "family_of",
    "groups_at_end",
    "parent_groups",
    "parse_algorithm",
    "parse_algorithms",
    "registry",
    "sort_key",
    "task_share",
    "valid_labels",
]
