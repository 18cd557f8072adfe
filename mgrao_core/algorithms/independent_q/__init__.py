"""``independent-q``: each child an independent learner with one value estimate per atomic type.

* :mod:`~mgrao_core.algorithms.independent_q.family`: the label, the parameters and each lane's state;
* :mod:`~mgrao_core.algorithms.independent_q.compiled`: the compiled steps the kernel calls (numba);
* :mod:`~mgrao_core.algorithms.independent_q.reference`: the dense reference step.
"""

from mgrao_core.algorithms.independent_q.family import FAMILY, LABEL, IndependentQ

__all__ = ["FAMILY", "LABEL", "IndependentQ"]
