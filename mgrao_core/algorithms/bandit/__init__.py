"""``bandit``: each child a gradient bandit over atomic types (Sutton and Barto, section 2.8).

* :mod:`~mgrao_core.algorithms.bandit.family`: the label, the parameter and each lane's state;
* :mod:`~mgrao_core.algorithms.bandit.compiled`: the compiled steps the kernel calls (numba);
* :mod:`~mgrao_core.algorithms.bandit.reference`: the dense reference step.
"""

from mgrao_core.algorithms.bandit.family import FAMILY, LABEL, GradientBandit

__all__ = ["FAMILY", "LABEL", "GradientBandit"]
