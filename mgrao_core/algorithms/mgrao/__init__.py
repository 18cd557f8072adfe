"""MG-RAO, the paper's multi-group learner: ``mgrao-x:y`` and ``mgrao-max`` (algorithms 1 and 2).

* :mod:`~mgrao_core.algorithms.mgrao.family`: the label grammar, MG-RAO's parameters and each
  lane's state (what the registry, the runner and the budget read);
* :mod:`~mgrao_core.algorithms.mgrao.compiled`: the compiled steps the kernel calls (numba, imported
  only by the kernel and the runner);
* :mod:`~mgrao_core.algorithms.mgrao.reference`: the dense reference step.
"""

from mgrao_core.algorithms.mgrao.family import FAMILY, MAX_LABEL, Mgrao, divisors, parent_groups, ratio_label, teams

__all__ = ["FAMILY", "MAX_LABEL", "Mgrao", "divisors", "parent_groups", "ratio_label", "teams"]
