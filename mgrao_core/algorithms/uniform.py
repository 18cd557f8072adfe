"""``uniform``: every child gives each atomic type the same share of its resource, and never learns.

The baseline of the paper's "% from uniform".
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from mgrao_core.algorithms.base import Algorithm, FixedFamily, LabelForm, World
from mgrao_core.algorithms.state import System

LABEL = "uniform"


class Uniform(FixedFamily):
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

    def fixed_weights(self, params: System, world: World, seed: int,
                      should_stop: Callable[[], bool] | None = None) -> np.ndarray:
        """``1 / n_types`` for every type of every child."""
        return np.full((params.n_children, params.n_types), 1.0 / params.n_types)


FAMILY = Uniform()
