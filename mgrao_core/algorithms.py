"""Algorithm labels (paper table "Summary of algorithm labels") and the parent groups they imply."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from mgrao_core.errors import ConfigError

UNIFORM = "uniform"
ORACLE = "oracle"
MGRAO_MAX = "mgrao-max"
_RATIO = re.compile(r"^mgrao-0*(\d{1,9}):0*(\d{1,9})$")


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


def parse_algorithm(label: str, n_parents: int, field: str = "algorithm", *, hint_groups: bool = True) -> Algorithm:
    """Turn a label into an :class:`Algorithm` for a system with ``n_parents`` parents.

    ``mgrao-x:1`` means x parent groups per child (paper: "an x:y ratio of parent-agent groups to
    each child-agent"); x must divide ``n_parents`` so that every group has the same size.

    Labels are read without case or surrounding spaces, and ratios without leading zeros: the
    returned ``label`` is the canonical spelling (``" MGRAO-05:1"`` is ``"mgrao-5:1"``).

    An unknown label's error lists the x that ``n_parents`` allows, unless ``hint_groups`` is false
    (a caller without a system, such as a sort key, passes a made-up ``n_parents``).

    Raises:
        ConfigError: an unknown label, y other than 1, or an x that does not divide the parents.
    """
    text = label.strip().lower() if isinstance(label, str) else None
    if text == UNIFORM or text == ORACLE:
        return Algorithm(text, text)
    if text == MGRAO_MAX:
        return Algorithm(text, "mgrao", n_parents)
    match = _RATIO.match(text) if text is not None else None
    if match is None:
        hint = "x being the parent groups per child, a whole number"
        if hint_groups:
            hint = f"{hint} dividing n_parents = {n_parents} ({', '.join(str(d) for d in divisors(n_parents))})"
        raise ConfigError(field, f"unknown algorithm {label!r}: use uniform, oracle, mgrao-max or mgrao-x:1, {hint}")
    groups, children = int(match.group(1)), int(match.group(2))
    if children != 1:
        raise ConfigError(field, f"{label}: only x:1 (groups per child) is supported, got y = {children}")
    if groups < 1 or groups > n_parents or n_parents % groups:
        raise ConfigError(
            field,
            f"{label}: x must be a divisor of n_parents = {n_parents} "
            f"(valid: {', '.join(str(d) for d in divisors(n_parents))})",
        )
    return Algorithm(f"mgrao-{groups}:1", "mgrao", groups)


def parse_algorithms(labels: list[str] | tuple[str, ...], n_parents: int) -> tuple[Algorithm, ...]:
    """Parse a non-empty list of distinct labels (field names ``algorithms[i]`` in errors).

    Two spellings of one algorithm (``mgrao-1:1`` and ``mgrao-01:1``) are a repeat.
    """
    if not labels:
        raise ConfigError("algorithms", "must name at least one algorithm")
    parsed = []
    seen: dict[str, int] = {}
    for i, label in enumerate(labels):
        algorithm = parse_algorithm(label, n_parents, f"algorithms[{i}]")
        parsed.append(algorithm)
        if algorithm.label in seen:
            raise ConfigError(
                f"algorithms[{i}]",
                f"repeats algorithms[{seen[algorithm.label]}] ({labels[i]!r} is {algorithm.label!r})",
            )
        seen[algorithm.label] = i
    return tuple(parsed)


def divisors(n: int) -> list[int]:
    """The positive divisors of ``n`` in increasing order."""
    return [d for d in range(1, n + 1) if n % d == 0]


def parent_groups(n_parents: int, n_groups: int) -> np.ndarray:
    """Group of each parent: parent ``p`` is in group ``floor(p * m / n_parents)``: docs/model.md ("MG-RAO")."""
    return (np.arange(n_parents) * n_groups) // n_parents
