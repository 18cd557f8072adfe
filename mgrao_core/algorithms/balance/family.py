"""``mgrao-balance[:M]``: MG-RAO whose children choose how many parent groups to learn, at most M.

Under ``learning_cost`` (docs/model.md, "The cost of learning") a group is not free: each child's tasks get
``equations.task_share`` of its resources, less the more groups it learns. The paper leaves "varying the balance of
resources allocated to learning versus task execution to future work"; this family varies it while it runs. Each
child keeps MG-RAO's rows (PW, trace and sample count per group: algorithms 1 and 2, exactly as ``mgrao-x:1``) for
the ``m`` groups it has, which start at one and only ever grow:

* **when**: every ``balance_every`` episodes, at the start of the episode, before the child fixes its allocation,
  a child that has not settled and has fewer than ``M`` groups decides;
* **split** if it has one group, or if the rows born of its last split differ by at least ``balance_tolerance *
  learning_cost``: the divergence is ``D = (1/m) sum_rows sum_j (r[j] - mu[j]) log(r[j] / mu[j])``, ``mu`` the
  mean of the row and its siblings (the rows copied from one row at the last split; the term is each row's
  symmetric Kullback-Leibler divergence to that mean). Rows that learned apart what their parents want are
  evidence that finer groups pay for what they cost;
* **otherwise settle**: the child keeps its ``m`` groups for the rest of the run;
* **a split** divides every group into ``q``, the smallest prime factor of ``M / m``: row ``g`` becomes rows ``g *
  q .. g * q + q - 1``, each a copy of its PW row and eligibility trace with a ``q``-th of its sample count, so the
  combined weights (algorithm 2) do not change; parent ``p`` goes to group ``floor(p * m' / n_parents)``, inside
  its old group since ``m`` divides ``m'`` divides ``n_parents`` (the nesting that makes a copy the right start).

Each episode a child's tasks get the share left by what it learns with its present ``m`` groups
(:meth:`Balance.learned_for`). Without a cost the threshold is 0, so a child splits at every decision up to ``M``
(``mgrao-max``'s groups for the bare label). The bound ``M`` is the memory: a child never keeps more than ``M`` rows,
and the engine allocates them from the start (:meth:`Balance.memory_per_child`). docs/algorithms.md
("Choosing the number of groups") gives the rule's reasons, its calibration and its known weaknesses.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from mgrao_core.algorithms.adaptive.family import FAMILY as ADAPTIVE
from mgrao_core.algorithms.adaptive.family import SNAPSHOTS, record_state, recorded_membership
from mgrao_core.algorithms.base import Algorithm, Family, LabelForm
from mgrao_core.algorithms.mgrao import FAMILY as MGRAO
from mgrao_core.algorithms.mgrao.family import check_divisor, divisors
from mgrao_core.algorithms.state import StateArray, System, nbytes, sizes_of
from mgrao_core.parameter import Parameter

NAME = "mgrao-balance"
RULE_NUMBERS = 2
"""What the rule keeps beside the rows: the child's group count and its last split's factor."""
_LABEL = re.compile(r"^mgrao-balance(?::0*(\d{1,9}))?$")


def balance_label(bound: int) -> str:
    """The canonical label of a bound of ``M`` groups, ``mgrao-balance:M`` (the bare label's bound is ``n_parents``)."""
    return f"{NAME}:{bound}"


def smallest_prime_factor(n: int) -> int:
    """The smallest prime factor of ``n >= 2`` (``n`` itself for a prime)."""
    d = 2
    while d * d <= n:
        if n % d == 0:
            return d
        d += 1
    return n


def next_split(groups: int, bound: int) -> int:
    """The factor ``q`` of a split from ``groups`` groups: the smallest prime factor of ``bound / groups``."""
    return smallest_prime_factor(bound // groups)


class Balance(Family):
    """MG-RAO that starts with one parent group per child and splits them while the split rows keep diverging."""

    name = NAME
    title = "MG-RAO, balanced groups"
    description = ("MG-RAO whose children choose their number of parent groups as they learn (the paper's future "
                   "work): each starts with one group and splits them every few episodes while the rows of its last "
                   "split differ by at least balance_tolerance times what learning costs (learning_cost), up to a "
                   "bound of M groups.")
    rank = 1  # beside MG-RAO: after uniform, before the oracle
    groups_change = True
    parameters = (
        Parameter("balance_every", "int", 10, "Episodes between two of mgrao-balance's decisions to split its groups.",
                  NAME, 1, 1_000_000),
        Parameter("balance_tolerance", "float", 30.0,
                  "mgrao-balance splits again while the rows of its last split differ (mean symmetric KL to their "
                  "siblings' mean) by at least balance_tolerance * learning_cost, and settles otherwise.",
                  NAME, 0.0, 1_000_000.0),
    )
    reads = MGRAO.own_parameters  # it learns with MG-RAO's update and blend
    state = (*MGRAO.state,  # MG-RAO's arrays for M rows (shared with its lanes: the same declarations)
             StateArray("balance_groups", ("lanes", "children"), "int64", fill=1,
                        help="each child's parent groups now"),
             StateArray("balance_last_split", ("lanes", "children"), "int64", fill=1,
                        help="the factor of each child's last split (1: none yet)"),
             StateArray("balance_settled", ("lanes", "children"), "bool",
                        help="whether the child has settled on its groups"),
             *(a for a in ADAPTIVE.state if a.name in ("membership", "episodes_seen")),
             *record_state())
    steps = "mgrao_core.algorithms.balance.compiled"
    reference = "mgrao_core.algorithms.balance.reference:children"
    _bare = LabelForm(NAME, "^mgrao-balance$", "up to n_parents groups per child (mgrao-max's memory)")
    _bounded = LabelForm("mgrao-balance:{M}", r"^mgrao-balance:0*(\d{1,9})$", "up to M groups per child",
                         "M", "the most parent groups per child, a whole number dividing n_parents")

    def parse(self, text: str, n_parents: int | None, field: str) -> Algorithm | None:
        """This family's algorithm for ``text``, or None (see :meth:`Family.parse`)."""
        match = _LABEL.match(text)
        if match is None:
            return None
        if match.group(1) is None:
            return Algorithm(NAME, self.name, n_parents or 0)
        bound = int(match.group(1))
        check_divisor(text, bound, n_parents, field, "M")
        return Algorithm(balance_label(bound), self.name, bound)

    def forms(self, n_parents: int | None) -> list[dict[str, Any]]:
        """The family's label forms (see :meth:`Family.forms`)."""
        return [self._bare.as_dict(), self._bounded.as_dict(valid=None if n_parents is None else divisors(n_parents))]

    def examples(self, n_parents: int | None) -> list[str]:
        """The bare label, and a bound of 10 groups where 10 divides n_parents."""
        bounded = [balance_label(10)] if n_parents is not None and n_parents > 10 and n_parents % 10 == 0 else []
        return [NAME, *bounded]

    def hint(self, n_parents: int | None) -> str:
        """How the family's labels are written."""
        hint = f"{NAME} or {NAME}:M, M being the most parent groups per child, a whole number"
        if n_parents is not None:
            hint = f"{hint} dividing n_parents = {n_parents}"
        return hint

    def colour_key(self, algorithm: Algorithm) -> int:
        """Green (slot 3), MG-RAO's 2-3 groups' slot: free beside uniform, 1:1, 5:1, max and the oracle."""
        return 3

    def order(self, algorithm: Algorithm) -> int:
        """After MG-RAO's and the adaptive configurations, by increasing bound (the bare label's, n_parents, last)."""
        return 2**62 + 2**40 + (2**39 if algorithm.label == NAME else algorithm.n_groups)

    def sizes(self, algorithm: Algorithm, params: System) -> dict[str, int]:
        """Every parent's group and :data:`~mgrao_core.algorithms.adaptive.SNAPSHOTS` recorded memberships."""
        return {"tracked_parents": params.n_parents, "tracked_children": params.n_children, "snapshots": SNAPSHOTS}

    def memory_per_child(self, algorithm: Algorithm, params: System) -> int:
        """Bytes of one child's learner state: MG-RAO's for the bound's ``M`` rows and the rule's numbers.

        The recorded memberships (the job view's figure) and the membership being recorded are not the learner's
        memory and are left out.
        """
        left_out = {"membership", *(a.name for a in record_state())}
        learner = tuple(a for a in self.state if a.name not in left_out)
        sizes = sizes_of(params, 1, algorithm.n_groups, self.sizes(algorithm, params))
        return nbytes(learner, sizes | {"children": 1, "tracked_children": 1, "learners": sizes["resources"]})

    def learned_for(self, groups: int, params: System) -> int:
        """The numbers a child keeps with ``groups`` groups: MG-RAO's rows (one split for every resource), the rule's.

        ``groups * (2 * n_types + 1) + 2``; what it pays for in an episode (``learning_cost``).
        """
        return groups * (2 * params.n_types + 1) + RULE_NUMBERS

    def learned_numbers(self, algorithm: Algorithm, params: System) -> int:
        """The most a child keeps: :meth:`learned_for` the bound's ``M`` groups (each episode it pays for its own)."""
        return self.learned_for(algorithm.n_groups, params)

    def learned_with(self, algorithm: Algorithm, params: System, groups: int) -> int:
        """What a child with ``groups`` groups keeps and pays for: :meth:`learned_for`."""
        return self.learned_for(groups, params)

    def initialise(self, arrays: Mapping[str, np.ndarray], lanes: np.ndarray, params: System) -> None:
        """One group per child, its row active (as ``mgrao-1:1``'s: the same operations); every parent in group 0.

        The other rows become active when a split gives them a trace, or with their first value.
        """
        arrays["rows"][lanes] = np.arange(arrays["rows"].shape[2], dtype=np.int64)
        arrays["slot"][lanes] = -1
        arrays["slot"][lanes, :, 0] = 0
        arrays["n_rows"][lanes] = 1
        arrays["membership"][lanes] = 0
        arrays["membership_history"][lanes, :, 0] = 0
        arrays["n_snapshots"][lanes] = 1

    def membership(self, arrays: Mapping[str, np.ndarray], lane: int, algorithm: Algorithm,
                   params: System) -> tuple[np.ndarray, int] | None:
        """Each child's recorded groups ``(children, snapshots, n_parents)``: one record per decision."""
        return recorded_membership(arrays, lane, params, params.balance_every)


FAMILY = Balance()
