"""``mgrao-x:1`` and ``mgrao-max``: MG-RAO, the paper's multi-group learner (algorithms 1 and 2).

Each child keeps one row of parent-group weights (PW) per group of parents: ``mgrao-x:1`` splits
the parents into x groups of equal size (x divides ``n_parents``; the paper's "x:y ratio of
parent-agent groups to each child-agent", y being 1), ``mgrao-max`` gives every parent its own
group and ``mgrao-1:1`` pools them all.

The family's parts sit side by side: this module (labels, parameters, lane state),
:mod:`~mgrao_core.algorithms.mgrao.compiled` (the kernel's steps) and
:mod:`~mgrao_core.algorithms.mgrao.reference` (the dense, literal algorithms 1 and 2).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from mgrao_core.algorithms.base import Algorithm, Family, LabelForm, invalid
from mgrao_core.algorithms.state import StateArray, System
from mgrao_core.parameter import Parameter

MAX_LABEL = "mgrao-max"
MIN_BOUNDED_GROUPS = 64
"""Children with at most this many parent groups keep every row active. Below it, dropping
negligible traces saves little, and the engine then performs exactly the floating-point operations
of the unbounded lazy update (so results stored by earlier versions re-run bit for bit)."""
GROUP_BLENDS = ("dkl-and-count", "dkl-only")
"""Algorithm 2's blending vector (``group_blend``): the paper's ``sumnorm(dkl) + sumnorm(count)`` (the
default), or ``sumnorm(dkl)`` alone, without the sample counts (docs/model.md, "MG-RAO")."""
_RATIO = re.compile(r"^mgrao-0*(\d{1,9}):0*(\d{1,9})$")


def divisors(n: int) -> list[int]:
    """The positive divisors of ``n`` in increasing order."""
    return [d for d in range(1, n + 1) if n % d == 0]


def parent_groups(n_parents: int, n_groups: int) -> np.ndarray:
    """Group of each parent: parent ``p`` is in group ``floor(p * m / n_parents)`` (docs/model.md, "MG-RAO")."""
    return (np.arange(n_parents) * n_groups) // n_parents


def check_divisor(text: str, value: int, n_parents: int | None, field: str, name: str) -> None:
    """Refuse the argument ``name`` (= ``value``) of label ``text`` unless it divides ``n_parents``.

    Without a system (``n_parents`` None) it need only be at least 1. Raises :class:`ConfigError` naming ``field``
    and, with a system, the valid values.
    """
    if n_parents is None:
        if value < 1:
            raise invalid(field, f"{text}: {name} must be a whole number of at least 1")
    elif value < 1 or value > n_parents or n_parents % value:
        raise invalid(field, f"{text}: {name} must be a divisor of n_parents = {n_parents} "
                             f"(valid: {', '.join(str(d) for d in divisors(n_parents))})")


def ratio_label(groups: int) -> str:
    """The canonical label of x groups per child, ``mgrao-x:1``."""
    return f"mgrao-{groups}:1"


class Mgrao(Family):
    """MG-RAO with x parent groups per child (``mgrao-x:1``), or one group per parent (``mgrao-max``)."""

    name = "mgrao"
    title = "MG-RAO"
    description = ("Each child learns a row of resource weights per group of parents from the values they "
                   "return (algorithm 1) and blends the rows by how informative and how used each is "
                   "(algorithm 2). More groups: a finer model that learns more slowly and needs more memory.")
    rank = 1
    parameters = (
        Parameter("learning_rate", "float", 0.1, "Learning rate alpha of the MG-RAO update.",
                  "mgrao", 0.0, 1.0, identity="always"),
        Parameter(
            "trace_decay", "float", 0.9, "Decay gamma of the replacing eligibility trace.",
            "mgrao", 0.001, 0.999, identity="always",
        ),
        Parameter(
            "temperature", "float", None,
            "Softmax temperature of the combined weights; empty means 1/n_types, 1 is paper-literal.",
            "mgrao", 1e-4, 100.0, nullable=True, identity="always",
        ),
        Parameter(
            "group_blend", "choice", GROUP_BLENDS[0],
            "Algorithm 2's blend of the group rows: dkl-and-count (the paper's sumnorm(dkl) + sumnorm(count)) "
            "or dkl-only (without the sample counts).",
            "mgrao", choices=GROUP_BLENDS,
        ),
    )
    reads = ("resource_credit",)  # declared with the resources (docs/model.md, "Several resources")
    state = (  # each child's PW and trace in lazy form (see the compiled module), its active rows and counts;
        # one learner per (child, resource): learner c * n_resources + r keeps child c's PW of resource r
        StateArray("Y", ("lanes", "learners", "groups", "n_types"), fill="uniform", help="PW, lazily"),
        StateArray("F", ("lanes", "learners", "groups", "n_types"), help="the eligibility trace, lazily"),
        StateArray("H", ("lanes", "learners", "groups"), help="each active row's pending update"),
        StateArray("cs", ("lanes", "learners", "groups"), fill=1.0, help="each active row's scale"),
        StateArray("G", ("lanes", "learners", "groups"), help="each active row's trace sum"),
        StateArray("k_since_rebase", ("lanes", "learners"), "int64", help="updates since the last rebase"),
        StateArray("rows", ("lanes", "learners", "groups"), "int64", help="the active rows, first n_rows"),
        StateArray("slot", ("lanes", "learners", "groups"), "int64", help="each row's place in rows (-1: inactive)"),
        StateArray("n_rows", ("lanes", "learners"), "int64", help="how many rows are active"),
        StateArray("counts", ("lanes", "learners", "groups"), help="parent agent sample counts"),
        StateArray("rebase_due", ("lanes", "learners"), "bool", help="a scale nears underflow: rebase first"),
        StateArray("row_kl", ("lanes", "learners", "groups"), fill=math.nan,
                   help="each row's dkl (algorithm 2), kept while the row is inactive (NaN: to be computed)"),
    )
    steps = "mgrao_core.algorithms.mgrao.compiled"
    reference = "mgrao_core.algorithms.mgrao.reference:children"
    _ratio = LabelForm("mgrao-{x}:1", r"^mgrao-0*(\d{1,9}):0*1$", "x parent groups per child",
                       "x", "parent groups per child, a whole number dividing n_parents")
    _max = LabelForm(MAX_LABEL, "^mgrao-max$", "one group per parent")

    def parse(self, text: str, n_parents: int | None, field: str) -> Algorithm | None:
        """This family's algorithm for ``text``, or None (see :meth:`Family.parse`)."""
        if text == MAX_LABEL:
            return Algorithm(MAX_LABEL, self.name, n_parents or 0)
        match = _RATIO.match(text)
        if match is None:
            return None
        groups, children = int(match.group(1)), int(match.group(2))
        if children != 1:
            raise invalid(field, f"{text}: only x:1 (groups per child) is supported, got y = {children}")
        check_divisor(text, groups, n_parents, field, "x")
        return Algorithm(ratio_label(groups), self.name, groups)

    def forms(self, n_parents: int | None) -> list[dict[str, Any]]:
        """The family's label forms (see :meth:`Family.forms`)."""
        return [self._ratio.as_dict(valid=None if n_parents is None else divisors(n_parents)), self._max.as_dict()]

    def examples(self, n_parents: int | None) -> list[str]:
        """Labels valid for the system (see :meth:`Family.examples`)."""
        ratios = [1] if n_parents is None else [d for d in divisors(n_parents) if d < n_parents]
        return [ratio_label(x) for x in ratios] + [MAX_LABEL]

    def hint(self, n_parents: int | None) -> str:
        """How the family's labels are written."""
        ratio = self._ratio.template.format(x="x")
        hint = f"{MAX_LABEL} or {ratio}, x being the parent groups per child, a whole number"
        if n_parents is not None:
            hint = f"{hint} dividing n_parents = {n_parents} ({', '.join(str(d) for d in divisors(n_parents))})"
        return hint

    def colour_key(self, algorithm: Algorithm) -> int:
        """1:1 blue (slot 1), max vermillion (2); other x by magnitude: 2-3 green, 4-7 pink, 8-15 yellow, 16+ orange.

        The palette holds two blues (1, 6) and two oranges (2, 5); the slots are chosen so that the
        configurations a job of the paper's systems shows together (1:1, a few x, max) take colours of
        different hues, and the second of a pair comes only with 16 or more groups (large's 25:1).
        """
        x = algorithm.n_groups
        if algorithm.label == MAX_LABEL:
            return 2
        if x == 1:
            return 1
        if x < 4:
            return 3
        if x < 8:
            return 4
        return 7 if x < 16 else 5

    def order(self, algorithm: Algorithm) -> int:
        """x:1 by increasing x, then max."""
        return 2**62 if algorithm.label == MAX_LABEL else algorithm.n_groups

    def learned_numbers(self, algorithm: Algorithm, params: System) -> int:
        """Per group a row of PW, one of its eligibility trace (``n_types`` each) and a sample count.

        With several resources, that for each resource's PW.
        """
        return algorithm.n_groups * (2 * params.n_types + 1) * getattr(params, "n_resources", 1)

    def initialise(self, arrays: Mapping[str, np.ndarray], lanes: np.ndarray, params: System) -> None:
        """The active rows of the children of ``lanes`` before the first episode.

        ``rows (lanes, children, groups)`` (the active rows of a child come first), ``slot`` (a row's
        place in ``rows``, -1 if inactive) and ``n_rows (lanes, children)``. With at most
        :data:`MIN_BOUNDED_GROUPS` groups every row is active and stays so; with more, none is yet: a
        row becomes active with the first value of its group.
        """
        rows, slot, n_rows, groups = arrays["rows"], arrays["slot"], arrays["n_rows"], arrays["groups"]
        rows[lanes] = np.arange(rows.shape[2], dtype=np.int64)
        slot[lanes] = rows[lanes]  # H, cs and G of a row are at its slot: where the row is, while all are active
        n_rows[lanes] = groups[lanes, None]
        for lane in lanes[groups[lanes] > MIN_BOUNDED_GROUPS]:
            slot[lane] = -1
            n_rows[lane] = 0

    def group_weights(self, arrays: Mapping[str, np.ndarray], lane: int, algorithm: Algorithm) -> np.ndarray | None:
        """The lane's final PW of every child, ``(children, n_groups, n_types)``."""
        return arrays["Y"][lane, :, : algorithm.n_groups].copy()


FAMILY = Mgrao()
