"""``mgrao-adaptive:x``: MG-RAO with x parent groups per child that the child re-forms as it learns.

A child runs MG-RAO's algorithms 1 and 2 on x rows of parent group weights (PW), exactly as
``mgrao-x:1``; what differs is which row a parent's values update. Every ``regroup_every`` episodes
(at the start of the episode, before the child fixes its allocation) the child re-forms its groups
from what it has seen of each parent, O(1) numbers per parent:

* ``returns``: the composite tasks the parent sent it (how often it sends tasks);
* the running mean and variance (Welford) of the parent's *type signature*, the mean atomic type of
  the tasks of one composite (a parent that always sends the same composite type has variance 0
  exactly; one whose composite type changes has a positive one);
* the running mean and variance of its *value spread*, the largest share of one composite's
  returned value (``max(atv) / sum(atv)``: a fixed value profile keeps it nearly constant, an
  unpredictable one does not).

The grouping rule (``regroup_by``):

* ``predictability`` (default): order the parents by (signature variance, spread variance, parent),
  a parent never heard from last;
* ``types``: order them by (signature variance, signature mean, spread variance, parent), likewise.

Then the ordered parents are cut into x consecutive groups of sizes as equal as possible (the
parent at place ``r`` goes to group ``floor(r * x / n_parents)``, so x need not divide
``n_parents``). Predictable parents come first and unpredictable ones gather in the last groups,
where they spoil no stable parent's model; with ``types``, parents that send the same types share a
row. Before the first regroup a parent ``p`` is in group ``floor(p * x / n_parents)``, as in
``mgrao-x:1``.

The rows stay where they are (docs/algorithms.md, "Adaptive parent groups"): the new groups, in
order, each take the row of the old group they share most members with (ties: the lower row), among
the rows not taken yet. A row's PW, eligibility trace and sample count are kept: they are the model
learned from the parents that mostly stay with it, and a reset would throw away what it learned.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from mgrao_core.algorithms.base import Algorithm, Family, LabelForm, invalid
from mgrao_core.algorithms.mgrao import FAMILY as MGRAO
from mgrao_core.algorithms.mgrao import parent_groups
from mgrao_core.algorithms.state import StateArray, System, nbytes, sizes_of
from mgrao_core.parameter import Parameter

NAME = "mgrao-adaptive"
SNAPSHOTS = 32
"""Memberships a child records over a run (the first, then after regroups): when they are full, every
other one is dropped and the child records every second regroup from then on (so the history spans the
run at even steps whatever its length)."""
RULES = ("predictability", "types")
"""The grouping rules (``regroup_by``), the default first (chosen on the calibration seeds 100-199;
docs/algorithms.md, "Adaptive parent groups")."""
_LABEL = re.compile(r"^mgrao-adaptive:0*(\d{1,9})$")


def adaptive_label(groups: int) -> str:
    """The canonical label of x adaptive groups per child, ``mgrao-adaptive:x``."""
    return f"{NAME}:{groups}"


def record_state() -> tuple[StateArray, ...]:
    """The arrays that record memberships for the job view (not the learner's memory)."""
    return (
        StateArray("membership_history", ("lanes", "children", "snapshots", "tracked_parents"), "int64",
                   help="each recorded membership: each parent's row"),
        StateArray("n_snapshots", ("lanes", "tracked_children"), "int64", help="memberships recorded"),
        StateArray("snapshot_stride", ("lanes", "tracked_children"), "int64", fill=1,
                   help="regroups between two recorded memberships"),
    )


def recorded_membership(arrays: Mapping[str, np.ndarray], lane: int, params: System,
                        every: int) -> tuple[np.ndarray, int]:
    """A lane's recorded memberships (:func:`record_state`) and the episodes between two, ``every`` between two changes.

    ``(children, snapshots, n_parents)``: the records every child made (as many as the child with fewest).
    """
    n = int(arrays["n_snapshots"][lane].min())
    stride = int(arrays["snapshot_stride"][lane].max())
    history = arrays["membership_history"][lane, :, :n, : params.n_parents].astype(np.int64)
    return history, stride * every


class Adaptive(Family):
    """MG-RAO whose x parent groups per child are re-formed every ``regroup_every`` episodes."""

    name = NAME
    title = "MG-RAO, adaptive groups"
    description = ("MG-RAO with x parent groups per child that the child re-forms every few episodes from "
                   "how predictable each parent's returns are and which types it sends (the paper's future "
                   "work): unpredictable parents gather in their own groups.")
    rank = 1  # beside MG-RAO: after uniform, before the oracle
    parameters = (
        Parameter("regroup_every", "int", 10, "Episodes between two regroupings of mgrao-adaptive's parent groups.",
                  NAME, 1, 1_000_000),
        Parameter("regroup_by", "choice", "predictability",
                  "mgrao-adaptive's grouping rule: predictability (how predictable the types and values a parent "
                  "returns are) or types (type predictability, then which types, then value predictability).",
                  NAME, choices=RULES),
    )
    reads = MGRAO.own_parameters  # it learns with MG-RAO's update and blend
    state = (*MGRAO.state,  # MG-RAO's arrays (shared with its lanes: the same declarations)
             StateArray("membership", ("lanes", "children", "tracked_parents"), "int64",
                        help="each parent's row (group)"),
             StateArray("returns", ("lanes", "children", "tracked_parents"),
                        help="composite tasks each parent sent the child"),
             StateArray("signature_mean", ("lanes", "children", "tracked_parents"),
                        help="running mean of each parent's type signature"),
             StateArray("signature_m2", ("lanes", "children", "tracked_parents"),
                        help="sum of squared deviations of each parent's type signature"),
             StateArray("spread_mean", ("lanes", "children", "tracked_parents"),
                        help="running mean of each parent's value spread"),
             StateArray("spread_m2", ("lanes", "children", "tracked_parents"),
                        help="sum of squared deviations of each parent's value spread"),
             StateArray("episodes_seen", ("lanes", "tracked_children"), "int64", help="episodes begun"),
             StateArray("votes", ("lanes", "tracked_parents"), "int64",
                        help="members shared with each row (the first x), while regrouping"),
             StateArray("taken", ("lanes", "tracked_parents"), "bool", help="rows taken (the first x), regrouping"),
             *record_state())
    steps = "mgrao_core.algorithms.adaptive.compiled"
    reference = "mgrao_core.algorithms.adaptive.reference:children"
    _form = LabelForm("mgrao-adaptive:{x}", r"^mgrao-adaptive:0*(\d{1,9})$",
                      "x parent groups per child, re-formed every regroup_every episodes",
                      "x", "parent groups per child, a whole number from 1 to n_parents")

    def parse(self, text: str, n_parents: int | None, field: str) -> Algorithm | None:
        """This family's algorithm for ``text``, or None (see :meth:`Family.parse`)."""
        match = _LABEL.match(text)
        if match is None:
            return None
        groups = int(match.group(1))
        if groups < 1 or (n_parents is not None and groups > n_parents):
            upto = "" if n_parents is None else f" to n_parents = {n_parents}"
            raise invalid(field, f"{text}: x must be a whole number from 1{upto}")
        return Algorithm(adaptive_label(groups), self.name, groups)

    def forms(self, n_parents: int | None) -> list[dict[str, Any]]:
        """The family's label form (see :meth:`Family.forms`)."""
        return [self._form.as_dict(valid=None if n_parents is None else list(range(1, n_parents + 1)))]

    def examples(self, n_parents: int | None) -> list[str]:
        """A few labels valid for the system (see :meth:`Family.examples`)."""
        xs = [2, 5] if n_parents is None else [x for x in (2, 5, 10) if x < n_parents]
        return [adaptive_label(x) for x in xs]

    def hint(self, n_parents: int | None) -> str:
        """How the family's labels are written."""
        upto = "" if n_parents is None else f" from 1 to n_parents = {n_parents}"
        return f"mgrao-adaptive:x, x being the parent groups per child, a whole number{upto}"

    def colour_key(self, algorithm: Algorithm) -> int:
        """Slot 6 (the second blue, beside MG-RAO's): a job shows its adaptive configuration beside fixed ones."""
        return 6

    def order(self, algorithm: Algorithm) -> int:
        """After MG-RAO's configurations (x:1 by x, then max), by increasing x."""
        return 2**62 + algorithm.n_groups

    def sizes(self, algorithm: Algorithm, params: System) -> dict[str, int]:
        """Statistics of every parent, counters of every child and :data:`SNAPSHOTS` recorded memberships."""
        return {"tracked_parents": params.n_parents, "tracked_children": params.n_children, "snapshots": SNAPSHOTS}

    def memory_per_child(self, algorithm: Algorithm, params: System) -> int:
        """Bytes of one child's learner state: MG-RAO's for x groups and the per-parent statistics.

        The recorded memberships (the job view's figure, ``SNAPSHOTS * n_parents`` int64) are not the
        learner's memory and are left out.
        """
        recorded = {a.name for a in record_state()}
        learner = tuple(a for a in self.state if a.name not in recorded)
        sizes = sizes_of(params, 1, algorithm.n_groups, self.sizes(algorithm, params))
        return nbytes(learner, sizes | {"children": 1, "tracked_children": 1, "learners": sizes["resources"]})

    def learned_numbers(self, algorithm: Algorithm, params: System) -> int:
        """MG-RAO's for x groups, and per parent its group and five statistics.

        The statistics: its returns, and the running mean and squared deviations of its type signature and of its
        value spread.
        """
        return MGRAO.learned_numbers(algorithm, params) + 6 * params.n_parents

    def initialise(self, arrays: Mapping[str, np.ndarray], lanes: np.ndarray, params: System) -> None:
        """MG-RAO's initial rows; parent ``p`` in group ``floor(p * x / n_parents)``, the first recorded membership."""
        MGRAO.initialise(arrays, lanes, params)
        for lane in lanes:
            start = parent_groups(params.n_parents, int(arrays["groups"][lane]))
            arrays["membership"][lane] = start
            arrays["membership_history"][lane, :, 0] = start
            arrays["n_snapshots"][lane] = 1

    def group_weights(self, arrays: Mapping[str, np.ndarray], lane: int, algorithm: Algorithm) -> np.ndarray | None:
        """The lane's final PW of every child, ``(children, x, n_types)``."""
        return arrays["Y"][lane, :, : algorithm.n_groups].copy()

    def membership(self, arrays: Mapping[str, np.ndarray], lane: int, algorithm: Algorithm,
                   params: System) -> tuple[np.ndarray, int] | None:
        """Each child's recorded memberships ``(children, snapshots, n_parents)`` and the episodes between two."""
        return recorded_membership(arrays, lane, params, params.regroup_every)


FAMILY = Adaptive()
