"""``uniform``: every child gives each atomic type the same share of its resource, and never learns.

The baseline of the paper's "% from uniform".
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mgrao_core.algorithms.base import Algorithm, FixedFamily, OneLabel, World
from mgrao_core.algorithms.state import System

LABEL = "uniform"


class Uniform(OneLabel, FixedFamily):
    """The fixed uniform allocation ``1 / n_types`` per type."""

    name = LABEL
    title = "Uniform"
    description = "Every child splits its resource equally over the atomic types and never learns: the baseline."
    rank = 0
    form_description = "the uniform allocation"

    def colour_key(self, algorithm: Algorithm) -> int:
        """The palette slot of the configuration."""
        return 0

    def fixed_weights(self, params: System, world: World, seed: int,
                      should_stop: Callable[[], bool] | None = None) -> np.ndarray:
        """``1 / n_types`` for every type of every child."""
        return np.full((params.n_children, params.n_types), 1.0 / params.n_types)


FAMILY = Uniform()
