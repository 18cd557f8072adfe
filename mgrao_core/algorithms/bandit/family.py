"""``bandit``: a gradient bandit over atomic types (Sutton and Barto, section 2.8), a baseline for MG-RAO.

Each child keeps one preference ``H`` per atomic type (starting at 0), no parent groups, and the
running mean of every value returned to it (its ``baseline``). Its allocation is ``w = softmax(H)``,
fixed at the start of each episode as MG-RAO's is. Each atomic task of type ``t`` the child performed
is a pull of arm ``t`` under that allocation: when its absolute value ``atv`` comes back (step 5), the
baseline takes it in first (``n += 1``, ``baseline += (atv - baseline) / n``: the mean of the values
up to and including this one, as in Sutton and Barto's second edition), then::

    H[t] += bandit_step * (atv - baseline) * (1 - w[t])
    H[j] -= bandit_step * (atv - baseline) * w[j]        for every j != t

with ``w`` the allocation in force in the episode (the policy the arm was pulled under).

Memory per child: ``n_types`` preferences and two numbers (the baseline and the count of values).
"""

from __future__ import annotations

from mgrao_core.algorithms.base import Algorithm, Family, OneLabel
from mgrao_core.algorithms.state import StateArray, System
from mgrao_core.parameter import Parameter

LABEL = "bandit"


class GradientBandit(OneLabel, Family):
    """A gradient bandit over atomic types: softmax of preferences, moved by each value against a baseline."""

    name = LABEL
    title = "Gradient bandit"
    description = ("Each child is a gradient bandit over atomic types (Sutton and Barto 2.8): softmax of one "
                   "preference per type, each returned value moving it against the running mean of values; "
                   "no parent groups. A standard baseline for MG-RAO.")
    rank = 3  # after MG-RAO (1) and independent-q (2), before the oracle (10)
    parameters = (
        Parameter("bandit_step", "float", 0.1,
                  "Step size of the gradient bandit's preference update (alpha of Sutton and Barto 2.8).",
                  LABEL, 0.0, 10_000.0),
    )
    state = (
        StateArray("preferences", ("lanes", "children", "n_types"), help="each child's preference H per type"),
        StateArray("bandit_baseline", ("lanes", "children"), help="each child's running mean of returned values"),
        StateArray("bandit_returns", ("lanes", "children"), help="how many values came back to each child"),
    )
    steps = "mgrao_core.algorithms.bandit.compiled"
    reference = "mgrao_core.algorithms.bandit.reference:children"
    form_description = "a gradient bandit over atomic types"

    def learned_numbers(self, algorithm: Algorithm, params: System) -> int:
        """A preference per type, the running mean of returned values and their count."""
        return params.n_types + 2

    def colour_key(self, algorithm: Algorithm) -> int:
        """Yellow (slot 7), MG-RAO's 8-15 groups' slot: free beside uniform, 1:1, 5:1, max, oracle and independent-q."""
        return 7


FAMILY = GradientBandit()
