"""``oracle``: each child's best fixed allocation given the true expected values (an upper bound).

The allocation itself is computed by :mod:`mgrao_core.oracle`.
"""

from __future__ import annotations

from typing import Any

from mgrao_core.algorithms.base import Algorithm, Family, LabelForm

LABEL = "oracle"


class Oracle(Family):
    """The best fixed allocation of each child, knowing every parent's expected values."""

    name = LABEL
    title = "Oracle"
    description = ("Each child's best fixed allocation given the true expected task values: no learner with a "
                   "fixed allocation does better in a stationary system.")
    rank = 2
    _form = LabelForm(LABEL, "^oracle$", "the best fixed allocation")

    def parse(self, text: str, n_parents: int | None, field: str) -> Algorithm | None:
        """This family's algorithm for ``text``, or None (see :meth:`Family.parse`)."""
        return Algorithm(LABEL, LABEL) if text == LABEL else None

    def forms(self, n_parents: int | None) -> list[dict[str, Any]]:
        """The family's label forms (see :meth:`Family.forms`)."""
        return [self._form.as_dict()]

    def examples(self, n_parents: int | None) -> list[str]:
        """Labels valid for the system (see :meth:`Family.examples`)."""
        return [LABEL]

    def hint(self, n_parents: int | None) -> str:
        """How the family's labels are written."""
        return LABEL

    def colour_key(self, algorithm: Algorithm) -> int:
        """The palette slot of the configuration: sky blue (6), beside 1:1's darker blue."""
        return 6


FAMILY = Oracle()
