"""The ``oracle`` baseline: the best fixed allocation given the true expected values.

A fixed allocation ``w`` of a child with resource ``ar`` earns, in expectation per episode,
``sum_t V[t] * q(w[t])``, where ``V[t]`` is the expected proportional value that type ``t``
carries over all composite tasks of an episode and ``q`` is the quality model (with load
sharing, the type's resource is shared among its ``L[t]`` instances). The oracle maximises that
sum over allocations (``w >= 0``, ``sum w = 1``):

* ``relative-linear``: ``q`` is linear up to its cap, so this is a fractional knapsack: fill the
  types in decreasing value per unit of weight up to the share that gives quality 1.
* ``hyperbolic`` and ``exponential``: ``q`` is concave, so the optimum equalises the marginal
  value ``V[t] * dq/dw`` of every type that gets resource (water-filling); the level is found by
  bisection.

Each model's side of this (its full-quality share, or the inverse of its marginal value) is written
beside the model in :mod:`mgrao_core.quality`.

No fixed allocation does better, so in a system whose task stream is stationary (single, large)
it bounds every algorithm from above in expectation. With several children each child gets the
best allocation for its own resource were it to receive every task (the parents' routing is not
known in advance), which specialising learners can beat; under volatility the oracle knows the
full system's task stream and, with ``rejoin_profile="new"``, only the initial profiles.

The system's dynamics (docs/model.md): with task frequencies, a parent's composite counts at its
arrival rate ``1 / period`` of its composite type (each phase is uniform, so that is the long-run share
of episodes it arrives in), in ``V`` and, with load sharing, in the expected loads; an unpredictable
parent counts at its expectation over a composite type drawn uniformly (each of its atomic types
``1 / types_per_composite`` of the value, by the symmetry of the Dirichlet profile and the noise) at that
type's arrival rate; a child's capability scales its resource per type (``ar / f``, as in the engine).
Under a ``schedule`` the oracle knows only the initial world: the allocation is the best fixed one
before the first event, not after it (it is not an upper bound there).

``V`` is estimated by Monte Carlo (:func:`expected_type_values`): :data:`EXPECTATION_SAMPLES`
draws of every parent's noisy proportional values from the seed's ``"oracle"`` stream. That is
the costly part (200 million noise values a seed at 1,000 parents and 200 types per composite);
the allocation itself is cheap. The draws and the sums are compiled
(:mod:`mgrao_core.engine.montecarlo`) and take a bounded number of noise values at a time, so
memory stays small and ``should_stop`` is polled every :data:`~mgrao_core.budget.ORACLE_DRAWS`
values (or every sample, when one is larger). They perform the plain numpy computation's
operations in its order, ``exp`` being numpy's own, so the weights are bit for bit those of
earlier versions (``tests/core/test_oracle.py`` keeps that computation as the reference).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from mgrao_core.budget import ORACLE_BATCH, ORACLE_DRAWS
from mgrao_core.engine.montecarlo import add_proportional_values, draw_scaled_normals
from mgrao_core.errors import Cancelled
from mgrao_core.params import SystemParams
from mgrao_core.quality import QualityModel, quality_model
from mgrao_core.world import World, composite_periods, stream, unpredictable_parents

EXPECTATION_SAMPLES = 1024
_BISECTIONS = 200


def expected_type_values(params: SystemParams, world: World, seed: int,
                         should_stop: Callable[[], bool] | None = None) -> np.ndarray:
    """``V[t]``: the expected proportional value of type ``t`` per episode.

    Estimated by Monte Carlo on the seed's own ``"oracle"`` stream; the profile alone would
    ignore the effect of the value noise on ``ctv``. The samples are summed in batches of
    :data:`~mgrao_core.budget.ORACLE_BATCH` and drawn :data:`~mgrao_core.budget.ORACLE_DRAWS` noise
    values at a time; ``should_stop`` is polled before every draw (:class:`Cancelled` when it
    returns True).
    """
    rng = stream(seed, "oracle")
    n_parents, per_composite = world.profiles.shape
    at_once = max(1, min(ORACLE_BATCH, ORACLE_DRAWS // (n_parents * per_composite)))
    factors = np.empty((at_once, n_parents, per_composite))
    batch_sums = np.empty_like(world.profiles)
    scratch = np.empty(per_composite)
    expected = np.zeros_like(world.profiles)
    for batch_start in range(0, EXPECTATION_SAMPLES, ORACLE_BATCH):
        batch = min(ORACLE_BATCH, EXPECTATION_SAMPLES - batch_start)
        for start in range(0, batch, at_once):
            if should_stop is not None and should_stop():
                raise Cancelled(f"stopped while estimating the oracle's values for seed {seed}")
            noise = factors[: min(at_once, batch - start)]
            draw_scaled_normals(rng, params.value_noise, noise)
            np.exp(noise, out=noise)  # numpy's exp, as the plain expression has it (see engine.montecarlo)
            add_proportional_values(world.profiles, noise, start == 0, batch_sums, scratch)
        expected += batch_sums
    expected /= EXPECTATION_SAMPLES
    parent_types, rates = _expected_parents(params, world, seed)
    if rates is not None:
        extra = len(parent_types) - len(expected)  # unpredictable parents' rows: 1 / types_per_composite each
        expected = np.concatenate([expected, np.full((extra, params.types_per_composite),
                                                     1.0 / params.types_per_composite)]) * rates[:, None]
    values = np.zeros(params.n_types)
    np.add.at(values, parent_types.ravel(), expected.ravel())
    return values


def arrival_rates(params: SystemParams) -> np.ndarray:
    """``(n_composite_types,)`` the share of episodes each composite type arrives in, ``1 / period``."""
    return 1.0 / composite_periods(params)


def _expected_parents(params: SystemParams, world: World, seed: int) -> tuple[np.ndarray, np.ndarray | None]:
    """The parents as the oracle counts them: rows of atomic types and the rate each row arrives at.

    ``(world.parent_types, None)`` when every composite arrives every episode and no parent is
    unpredictable (the computation of earlier versions, bit for bit). Otherwise a parent's row arrives at its
    composite type's rate, and an unpredictable parent's row (rate 0) is replaced by one row per composite
    type at ``rate / n_composite_types``, appended after the parents' rows: its composite type is drawn
    uniformly every episode.
    """
    rates = arrival_rates(params)
    unpredictable = unpredictable_parents(params, stream(seed, "unpredictable"))
    if not len(unpredictable) and (rates == 1.0).all():
        return world.parent_types, None
    per_parent = rates[np.arange(params.n_parents) % params.n_composite_types]
    if not len(unpredictable):
        return world.parent_types, per_parent
    per_parent = per_parent.copy()
    per_parent[unpredictable] = 0.0  # replaced by the rows below
    n = params.n_composite_types
    types = np.concatenate([world.parent_types] + [world.composite_types] * len(unpredictable))
    rows = np.concatenate([per_parent] + [rates / n] * len(unpredictable))
    return types, rows


def type_loads(params: SystemParams, world: World, seed: int = 0) -> np.ndarray:
    """``L[t]``: instances of type ``t`` per episode in the full system (1 without load sharing).

    With task frequencies or unpredictable parents, the expected instances (each parent's at its arrival rate).
    """
    if not params.load_sharing:
        return np.ones(params.n_types)
    parent_types, rates = _expected_parents(params, world, seed)
    if rates is None:
        loads = np.bincount(parent_types.ravel(), minlength=params.n_types).astype(float)
    else:
        loads = np.bincount(parent_types.ravel(), weights=np.repeat(rates, params.types_per_composite),
                            minlength=params.n_types)
    return np.maximum(loads, 1.0)


def _knapsack(params: SystemParams, model: QualityModel, values: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """relative-linear: fill types by value per unit weight up to their full-quality share."""
    full_quality_share = model.full_quality_share(loads, params.n_types, params.quality_at_uniform)
    weights = np.zeros(params.n_types)
    budget = 1.0
    for t in np.argsort(-(values / loads), kind="stable"):
        if budget <= 0 or values[t] <= 0:
            break
        weights[t] = min(full_quality_share[t], budget)
        budget -= weights[t]
    if budget > 0:  # every valued type is at quality 1: spread what is left evenly
        weights += budget / params.n_types
    return weights


def _weights_at_level(params: SystemParams, model: QualityModel, values: np.ndarray, per_weight: np.ndarray,
                      level: float) -> np.ndarray:
    """The weight of each type whose marginal value ``V * dq/dw`` equals ``level`` (0 if below)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        w = model.weights_at_level(values, per_weight, params.half_saturation, level)
    return np.where(values > 0, np.maximum(w, 0.0), 0.0)


def _water_filling(params: SystemParams, model: QualityModel, values: np.ndarray,
                   per_weight: np.ndarray) -> np.ndarray:
    """hyperbolic, exponential: the allocation that equalises the marginal values (bisection)."""
    if not (values > 0).any():
        return np.full(params.n_types, 1.0 / params.n_types)
    high = float(np.max(values * per_weight) / params.half_saturation)  # the largest marginal value at w = 0
    low = high
    while _weights_at_level(params, model, values, per_weight, low).sum() < 1.0:
        low /= 2.0
    for _ in range(_BISECTIONS):
        middle = np.sqrt(low * high)
        if _weights_at_level(params, model, values, per_weight, middle).sum() >= 1.0:
            low = middle
        else:
            high = middle
        if high - low <= 1e-15 * high:
            break
    weights = _weights_at_level(params, model, values, per_weight, low)
    return weights / weights.sum()


def oracle_weights(params: SystemParams, world: World, seed: int,
                   should_stop: Callable[[], bool] | None = None) -> np.ndarray:
    """The optimal fixed resource weights, ``(n_children, n_types)``, each row summing to 1."""
    model = quality_model(params.quality_model)
    values = expected_type_values(params, world, seed, should_stop)
    loads = type_loads(params, world, seed)
    if model.full_quality_share is not None:  # linear: the child's resource cancels out
        return np.tile(_knapsack(params, model, values, loads), (params.n_children, 1))
    return np.stack([_water_filling(params, model, values, resource / loads) for resource in world.type_resources])
