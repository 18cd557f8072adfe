"""The ``oracle`` baseline: the best fixed allocation given the true expected values.

With ``q = min(1, quality_at_uniform * n_types * w[t])`` the expected utility of a fixed
allocation ``w`` is ``sum_t V[t] * q(w[t])``, where ``V[t]`` is the expected proportional value
that type ``t`` carries over all composite tasks of an episode. That is a fractional knapsack:
fill the types in decreasing ``V[t]`` up to the share that gives quality 1, until the resource is
spent. No fixed allocation does better, so in a system whose task stream is stationary (single,
large) it bounds every algorithm from above in expectation. In the multi-child system it is the
best allocation *common to all children*, which specialising learners can beat; under volatility
with ``rejoin_profile="new"`` it knows only the initial profiles.
"""

from __future__ import annotations

import numpy as np

from mgrao_core.params import SystemParams
from mgrao_core.world import World, stream

EXPECTATION_SAMPLES = 1024


def expected_type_values(params: SystemParams, world: World, seed: int) -> np.ndarray:
    """``V[t]``: the expected proportional value of type ``t`` per episode.

    Estimated by Monte Carlo on the seed's own ``"oracle"`` stream; the profile alone would
    ignore the effect of the value noise on ``ctv``.
    """
    rng = stream(seed, "oracle")
    expected = np.zeros_like(world.profiles)
    remaining = EXPECTATION_SAMPLES
    while remaining:
        batch = min(remaining, 128)
        noisy = world.profiles * np.exp(params.value_noise * rng.standard_normal((batch,) + world.profiles.shape))
        expected += (noisy / noisy.sum(axis=2, keepdims=True)).sum(axis=0)
        remaining -= batch
    expected /= EXPECTATION_SAMPLES
    values = np.zeros(params.n_types)
    np.add.at(values, world.parent_types.ravel(), expected.ravel())
    return values


def oracle_weights(params: SystemParams, world: World, seed: int) -> np.ndarray:
    """The optimal fixed resource weights ``w`` (summing to 1) for the seed's world."""
    values = expected_type_values(params, world, seed)
    full_quality_share = 1.0 / (params.quality_at_uniform * params.n_types)
    weights = np.zeros(params.n_types)
    budget = 1.0
    for t in np.argsort(-values, kind="stable"):
        if budget <= 0 or values[t] <= 0:
            break
        weights[t] = min(full_quality_share, budget)
        budget -= weights[t]
    if budget > 0:  # every valued type is at quality 1: spread what is left evenly
        weights += budget / params.n_types
    return weights
