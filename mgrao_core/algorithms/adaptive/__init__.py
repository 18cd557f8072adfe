"""Adaptive parent groups, ``mgrao-adaptive:x``: MG-RAO whose children re-form their x parent groups.

The paper's future work ("adaptive parent-agent groups ... where the makeup of these groups changes
according to the variability of frequency distribution of parent agents' resource requests"):

* :mod:`~mgrao_core.algorithms.adaptive.family`: the label grammar, the parameters, each lane's
  state and the grouping rule's statement (what the registry, the runner and the budget read);
* :mod:`~mgrao_core.algorithms.adaptive.compiled`: the compiled steps the kernel calls (MG-RAO's
  algorithms 1 and 2, :mod:`mgrao_core.algorithms.mgrao.compiled`, plus the per-parent statistics
  and the regrouping);
* :mod:`~mgrao_core.algorithms.adaptive.reference`: the dense reference step.
"""

from mgrao_core.algorithms.adaptive.family import FAMILY, SNAPSHOTS, Adaptive, adaptive_label

__all__ = ["FAMILY", "SNAPSHOTS", "Adaptive", "adaptive_label"]
