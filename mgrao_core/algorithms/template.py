"""A documented template of a learner family: copy it to start a new algorithm (docs/algorithms.md).

Not registered (it is not in :data:`mgrao_core.algorithms.FAMILIES`), so nothing runs it; the tests
check that it still satisfies the interface. Its learner is deliberately trivial: each child adds up
the values each atomic type brings back and gives each type a share proportional to ``1 +`` its
total. A real family replaces the five parts marked below:

1. the label grammar (:meth:`parse`, :meth:`forms`, :meth:`examples`, :meth:`hint`, :meth:`colour_key`);
2. its own parameters (:attr:`parameters`: listed in the schema after the quality's, once registered);
3. each lane's state (:attr:`state`, shapes in named sizes: the runner allocates it, the budget counts it);
4. its steps: compiled in :mod:`~mgrao_core.algorithms.template_steps` (what the kernel calls) and dense
   in :class:`TemplateChild` (what :mod:`mgrao_core.reference` runs, for the equivalence tests);
5. what a child learns and keeps (:meth:`learned_numbers`: what ``learning_cost`` prices).
"""

from __future__ import annotations

import numpy as np

from mgrao_core.algorithms.base import Algorithm, Family, OneLabel, ReferenceChild, World
from mgrao_core.algorithms.state import StateArray, System
from mgrao_core.parameter import Parameter

LABEL = "template"


class TemplateChild(ReferenceChild):
    """The dense reference step: the same rule as the compiled steps, in plain numpy."""

    def __init__(self, params: System) -> None:
        self.prior = params.template_prior if hasattr(params, "template_prior") else 1.0
        self.totals = np.zeros(params.n_types)

    def allocation(self) -> np.ndarray:
        """A share of the resource proportional to ``prior +`` each type's total value."""
        shares = self.prior + self.totals
        return shares / shares.sum()

    def learn(self, parent: int, task_type: int, value: float) -> None:
        """Add the value to its type's total."""
        self.totals[task_type] += value


class Template(OneLabel, Family):
    """A trivial learner: shares proportional to ``1 +`` each type's total returned value."""

    name = LABEL
    title = "Template"
    description = "Each child gives each type a share proportional to 1 + the values that type brought back."
    rank = 3  # after the oracle in views
    parameters = (  # 2. a family's own parameters (names must not clash with any other's)
        Parameter("template_prior", "float", 1.0, "The template's prior total of every type.", LABEL, 0.0, 10.0),
    )
    state = (  # 3. each lane's arrays; a shape names sizes of mgrao_core.algorithms.state.SIZES
        StateArray("totals", ("lanes", "children", "n_types"), help="each type's total returned value"),
    )
    steps = "mgrao_core.algorithms.template_steps"  # 4. the compiled steps the kernel calls (an entry: loaded
    reference = "mgrao_core.algorithms.template:reference_children"  # by the layer that runs them) and the dense one
    form_description = "the template learner"

    def learned_numbers(self, algorithm: Algorithm, params: System) -> int:  # 5. what learning_cost prices
        """Each type's total returned value."""
        return params.n_types

    # 1. the label grammar

    def colour_key(self, algorithm: Algorithm) -> int:
        """The palette slot of the configuration."""
        return 7



def reference_children(params: System, algorithm: Algorithm, world: World, seed: int) -> list[ReferenceChild]:
    """The dense reference step's children: one :class:`TemplateChild` per child."""
    return [TemplateChild(params) for _ in range(params.n_children)]


FAMILY = Template()
