"""``mgrao-balance``: MG-RAO whose children choose their number of parent groups as they learn.

The paper's future work on the cost of learning ("we leave varying the balance of resources allocated to
learning versus task execution to future work"; "more resources allows for more, smaller groups"):

* :mod:`~mgrao_core.algorithms.balance.family`: the label grammar, the parameters, each lane's state and the
  rule's statement (what the registry, the runner and the budget read);
* :mod:`~mgrao_core.algorithms.balance.compiled`: the compiled steps the kernel calls (MG-RAO's algorithms 1 and
  2, :mod:`mgrao_core.algorithms.mgrao.compiled`, plus the splits);
* :mod:`~mgrao_core.algorithms.balance.reference`: the dense reference step.
"""

from mgrao_core.algorithms.balance.family import FAMILY, NAME, Balance, balance_label, next_split

__all__ = ["FAMILY", "NAME", "Balance", "balance_label", "next_split"]
