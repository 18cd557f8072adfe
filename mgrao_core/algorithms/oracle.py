"""``oracle``: each child's best fixed allocation given the true expected values (an upper bound).

The allocation itself is computed by :mod:`mgrao_core.oracle`, from the seed's own ``"oracle"`` stream.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mgrao_core.algorithms.base import Algorithm, FixedFamily, OneLabel, World, load
from mgrao_core.algorithms.state import System

LABEL = "oracle"
COMPUTATION = "mgrao_core.oracle:oracle_weights"
"""Where the allocation is computed (an entry, loaded when an oracle runs: it compiles a Monte Carlo)."""
ORACLE_BATCH = 128
"""Monte-Carlo samples of the oracle's expected values summed apart before they are added to the
total: fixes the order of the floating-point sums (a different batch gives different last bits)."""
ORACLE_DRAWS = 262_144
"""Noise values of the oracle's Monte-Carlo estimate drawn at once (2 MiB), or one sample's when that
is more; ``should_stop`` is polled between draws."""


def bound_caveats(params: System) -> list[str]:
    """Why, in a system of ``params``, the oracle's mean is no upper bound on what a learner can reach (none: it is).

    It is the best *fixed* allocation for a stationary task stream of one child with one resource
    (docs/model.md, "The oracle's expected values"): each departure from that is a way to beat it.
    """
    reasons = []
    if params.n_children > 1:
        reasons.append("several children: each child's allocation assumes it receives every task, and children "
                       "that specialise can beat it")
    if getattr(params, "sparse", False):
        reasons.append("a sparse world: each child's allocation assumes every parent's tasks, though only the "
                       "parents linked to it send it any, so a child that learns its neighbours' can beat it")
    if params.n_resources > 1:
        reasons.append("several resources: it is the best single split applied to every resource, which a learner "
                       "splitting each resource on its own can beat")
    if params.leave_probability > 0 or params.join_probability > 0:
        reasons.append("parents leave and rejoin: a learner that follows who is present can beat the best fixed "
                       "allocation")
    if any(event.change != "frequencies" for event in params.schedule):
        reasons.append("a schedule changes profiles or composites: the oracle knows only the initial world")
    if params.frequency_profile != "constant" or any(event.change == "frequencies" for event in params.schedule):
        reasons.append("composite types arrive periodically: a learner that follows the arrivals can beat the best "
                       "fixed allocation")
    if params.tasks_can_fail:
        reasons.append("tasks can fail (task_need): it maximises the expected quality as if none could, so a type it "
                       "gives too little fails, and a learner that keeps each type's need can beat it")
    return reasons


class Oracle(OneLabel, FixedFamily):
    """The best fixed allocation of each child, knowing every parent's expected values."""

    name = LABEL
    title = "Oracle"
    description = ("Each child's best fixed allocation given the true expected task values: no learner with a "
                   "fixed allocation does better in a stationary system. With several resources it is the best "
                   "single split applied to every resource: not optimal, and no upper bound for a learner that "
                   "splits each resource on its own.")
    rank = 10  # last: families between MG-RAO (1) and the oracle take 2 to 9
    streams = {"oracle": 5}
    form_description = "the best fixed allocation"

    def colour_key(self, algorithm: Algorithm) -> int:
        """The palette slot of the configuration: sky blue (6), beside 1:1's darker blue."""
        return 6

    def fixed_weights(self, params: System, world: World, seed: int,
                      should_stop: Callable[[], bool] | None = None) -> np.ndarray:
        """The best fixed allocation of each child (see :func:`mgrao_core.oracle.oracle_weights`)."""
        return load(COMPUTATION)(params, world, seed, should_stop=should_stop)

    def preparation_bytes(self, params: System, n_seeds: int) -> int:
        """The Monte-Carlo temporaries of the expected values (one seed at a time) and every seed's weights."""
        per_composite = params.n_parents * params.types_per_composite
        return 8 * (max(ORACLE_DRAWS, per_composite) + 2 * per_composite + params.types_per_composite
                    + 3 * params.n_types + n_seeds * params.n_children * params.n_types)


FAMILY = Oracle()
