"""``uniform``: every child gives each atomic type the same share of its resource, and never learns.

The baseline of the paper's "% from uniform".
"""

from __future__ import annotations

from typing import Any

from mgrao_core.algorithms.base import Algorithm, Family, LabelForm

LABEL = "uniform"


class Uniform(Family):
    """The fixed uniform allocation ``1 / n_types`` per type."""

    name = LABEL
    title = "Uniform"
    description = "Every child splits its resource equally over the atomic types and never learns: the baseline."
    rank = 0
    _form = LabelForm(LABEL, "^uniform$", "the uniform allocation")

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
        """The palette slot of the configuration."""
        return 0


FAMILY = Uniform()
