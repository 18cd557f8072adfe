"""``independent-q``: a standard independent learner over atomic types, a baseline for MG-RAO.

Each child keeps one number per atomic type, ``Q`` (starting at 0), and no parent groups: the
single model of an independent learner in the multi-agent literature. When the absolute value
``atv`` of an atomic task of type ``t`` comes back (step 5), ``Q[t] += q_learning_rate * (atv -
Q[t])`` (an exponential running mean of what type ``t`` returns); at the start of each episode the
child fixes its allocation ``softmax(Q / q_temperature)`` for the episode, as MG-RAO does.

Memory per child: ``n_types`` numbers. docs/algorithms.md gives the formulas and how the defaults
were chosen (``benchmarks/calibrate_learners.py``).
"""

from __future__ import annotations

from mgrao_core.algorithms.base import Algorithm, Family, OneLabel
from mgrao_core.algorithms.state import StateArray, System
from mgrao_core.parameter import Parameter

LABEL = "independent-q"


class IndependentQ(OneLabel, Family):
    """Independent Q-learning over atomic types: one running value per type, softmax allocation."""

    name = LABEL
    title = "Independent Q"
    description = ("Each child keeps one running value per atomic type (no parent groups) and gives each type "
                   "a softmax share of its resource: a standard independent learner, a baseline for MG-RAO.")
    rank = 2  # after MG-RAO (1), before the bandit (3) and the oracle (10)
    parameters = (
        Parameter("q_learning_rate", "float", 0.001,
                  "Step of independent-q's running value per type: Q[t] += rate * (atv - Q[t]).",
                  LABEL, 0.0, 1.0),
        Parameter("q_temperature", "float", 0.01,
                  "Softmax temperature of independent-q's allocation softmax(Q / temperature).",
                  LABEL, 1e-4, 100.0),
    )
    state = (
        StateArray("q_values", ("lanes", "children", "n_types"), help="each child's running value Q per type"),
    )
    steps = "mgrao_core.algorithms.independent_q.compiled"
    reference = "mgrao_core.algorithms.independent_q.reference:children"
    form_description = "independent Q-learning over atomic types"

    def learned_numbers(self, algorithm: Algorithm, params: System) -> int:
        """A running value per type."""
        return params.n_types

    def colour_key(self, algorithm: Algorithm) -> int:
        """Bluish green (slot 3), MG-RAO's 2-3 groups' slot.

        Every slot is taken by the paper's configurations and the oracle (large shows eight). A job
        comparing the learners with MG-RAO shows uniform (0), 1:1 (1), max (2) and the oracle (6),
        mostly with one x:1 of 5 (4): 3 and 7 stay free, and green is furthest from those hues.
        """
        return 3


FAMILY = IndependentQ()
