"""Algorithm labels (paper table "Summary of algorithm labels") and the parent groups they imply."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from mgrao_core.errors import ConfigError

UNIFORM = "uniform"
ORACLE = "oracle"
MGRAO_MAX = "mgrao-max"
_RATIO = re.compile(r"^mgrao-(\d+):(\d+)$")


@dataclass(frozen=True)
class Algorithm:
    """A parsed algorithm label.

    Attributes:
        label: the label as given, e.g. ``"mgrao-5:1"``.
        kind: ``"uniform"``, ``"oracle"`` or ``"mgrao"``.
        n_groups: parent groups per child (MG-RAO only; 0 otherwise).
    """

    label: str
    kind: str
    n_groups: int = 0


def parse_algorithm(label: str, n_parents: int, field: str = "algorithm") -> Algorithm:
    """Turn a label into an :class:`Algorithm` for a system with ``n_parents`` parents.

    ``mgrao-x:1`` means x parent groups per child (paper: "an x:y ratio of parent-agent groups to
    each child-agent"); x must divide ``n_parents`` so that every group has the same size.

    Raises:
        ConfigError: an unknown label, y other than 1, or an x that does not divide the parents.
    """
    if label == UNIFORM or label == ORACLE:
        return Algorithm(label, label)
    if label == MGRAO_MAX:
        return Algorithm(label, "mgrao", n_parents)
    match = _RATIO.match(label) if isinstance(label, str) else None
    if match is None:
        raise ConfigError(
            field, f"unknown algorithm {label!r}: use uniform, oracle, mgrao-max or mgrao-x:1"
        )
    groups, children = int(match.group(1)), int(match.group(2))
    if children != 1:
        raise ConfigError(field, f"{label}: only x:1 (groups per child) is supported, got y = {children}")
    if groups < 1 or groups > n_parents or n_parents % groups:
        raise ConfigError(
            field,
            f"{label}: x must be a divisor of n_parents = {n_parents} "
            f"(valid: {', '.join(str(d) for d in divisors(n_parents))})",
        )
    return Algorithm(label, "mgrao", groups)


def parse_algorithms(labels: list[str] | tuple[str, ...], n_parents: int) -> tuple[Algorithm, ...]:
    """Parse a non-empty list of distinct labels (field names ``algorithms[i]`` in errors)."""
    if not labels:
        raise ConfigError("algorithms", "must name at least one algorithm")
    if len(set(labels)) != len(labels):
        raise ConfigError("algorithms", "must not repeat a label")
    return tuple(parse_algorithm(lab, n_parents, f"algorithms[{i}]") for i, lab in enumerate(labels))


def divisors(n: int) -> list[int]:
    """The positive divisors of ``n`` in increasing order."""
    return [d for d in range(1, n + 1) if n % d == 0]


def parent_groups(n_parents: int, n_groups: int) -> np.ndarray:
    """Group of each parent: parent ``p`` is in group ``floor(p * m / n_parents)`` (SIMULATION.md)."""
    return (np.arange(n_parents) * n_groups) // n_parents
