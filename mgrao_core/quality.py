"""The quality models: what an atomic task's quality is, given the resource a child gives its type.

Each model is written here once, in three forms side by side:

* its numpy form, over arrays: the dense reference's (:mod:`mgrao_core.reference`) and, through
  :func:`atomic_quality`, :attr:`SystemParams.effective_absent_quality
  <mgrao_core.params.SystemParams.effective_absent_quality>`'s;
* its compiled form, one task at a time, as the kernel computes it: plain Python over scalars that
  :func:`compiled_atomic_quality` hands to numba, so that importing this module (the parameter
  schema does) loads no numba;
* the inverse the ``oracle`` baseline (:mod:`mgrao_core.oracle`) needs: for a concave model, the
  weight at which the marginal value ``V * dq/dw`` equals a level (water-filling); for the linear
  one, the weight at which quality reaches 1 (a fractional knapsack).

:data:`QUALITY_MODELS` registers them by name, each with the integer code the kernel dispatches on
(the ``quality_model`` of :class:`~mgrao_core.engine.Environment`). An unknown name raises
:class:`~mgrao_core.errors.ConfigError` naming it; an unknown code makes the compiled form NaN.
Neither ever falls through to another model. Both forms perform the operations of the paper's
definitions in the same order as before this module gathered them, so the numbers are bit for bit
those of earlier versions. They agree bit for bit with each other too, except exponential's, whose
``expm1`` is numpy's own in one and the C library's (numba's) in the other: at most 1 ulp apart.

The kernel inlines the compiled forms, and numba keys its cache of the kernel on the kernel's own
file alone: :mod:`mgrao_core.engine.cache` therefore hashes this file with the engine's sources.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from mgrao_core.errors import ConfigError

HYPERBOLIC = 0
EXPONENTIAL = 1
RELATIVE_LINEAR = 2


class QualityParams(Protocol):
    """The parameters a quality model reads (:class:`~mgrao_core.params.SystemParams` has them)."""

    quality_model: str
    n_types: int
    half_saturation: float
    quality_at_uniform: float
    quality_floor: float


def resource_amount(weight: np.ndarray, resource: float, load: np.ndarray | float = 1.0) -> np.ndarray:
    """Agent resource allocation ``x = w[tp] * ar[c]`` (paper definition), per instance of the type.

    ``load`` is the number of instances of the type the child receives in the episode when
    ``load_sharing`` is on (the resource is shared among them), 1 otherwise.
    """
    return np.asarray(weight, dtype=float) * resource / load


# ---- hyperbolic: q = x / (x + h) -------------------------------------------------------------------


def hyperbolic_quality(x: np.ndarray, half_saturation: float) -> np.ndarray:
    """``q = x / (x + h)``: 0 without resource, 1/2 at ``x = h``, saturating towards 1."""
    return x / (x + half_saturation)


def _hyperbolic(weight: np.ndarray, resource: float, load: np.ndarray | float, params: QualityParams) -> np.ndarray:
    return hyperbolic_quality(resource_amount(weight, resource, load), params.half_saturation)


def hyperbolic_task_quality(weight, resource, load, env):
    """Compiled form of :func:`hyperbolic_quality` for one task (``env``: the kernel's environment)."""
    x = weight * resource / load
    return x / (x + env.half_saturation)


def hyperbolic_weights_at_level(values: np.ndarray, per_weight: np.ndarray, half_saturation: float,
                                level: float) -> np.ndarray:
    """Solves ``V a h / (a w + h)^2 = level`` for ``w`` (``a``: the resource per unit of weight)."""
    return (np.sqrt(values * per_weight * half_saturation / level) - half_saturation) / per_weight


# ---- exponential: q = 1 - exp(-x / h) --------------------------------------------------------------


def exponential_quality(x: np.ndarray, half_saturation: float) -> np.ndarray:
    """``q = 1 - exp(-x / h)`` (computed as ``-expm1(-x / h)``)."""
    return -np.expm1(-x / half_saturation)


def _exponential(weight: np.ndarray, resource: float, load: np.ndarray | float, params: QualityParams) -> np.ndarray:
    return exponential_quality(resource_amount(weight, resource, load), params.half_saturation)


def exponential_task_quality(weight, resource, load, env):
    """Compiled form of :func:`exponential_quality` for one task (``env``: the kernel's environment)."""
    x = weight * resource / load
    return -math.expm1(-x / env.half_saturation)


def exponential_weights_at_level(values: np.ndarray, per_weight: np.ndarray, half_saturation: float,
                                 level: float) -> np.ndarray:
    """Solves ``V a / h * exp(-a w / h) = level`` for ``w`` (``a``: the resource per unit of weight)."""
    return half_saturation / per_weight * np.log(values * per_weight / (half_saturation * level))


# ---- relative-linear: q = min(1, quality_at_uniform * n_types * w) ---------------------------------


def relative_linear_quality(weight: np.ndarray, n_types: int, quality_at_uniform: float,
                            load: np.ndarray | float = 1.0) -> np.ndarray:
    """``q = min(1, quality_at_uniform * x / (ar / n_types))``: the first reading.

    That is ``quality_at_uniform * n_types * w[tp]`` capped at 1: the child's own resource ``ar``
    cancels out.
    """
    return np.minimum(1.0, quality_at_uniform * n_types * (np.asarray(weight, dtype=float) / load))


def _relative_linear(weight: np.ndarray, resource: float, load: np.ndarray | float,
                     params: QualityParams) -> np.ndarray:
    return relative_linear_quality(weight, params.n_types, params.quality_at_uniform, load)


def relative_linear_task_quality(weight, resource, load, env):
    """Compiled form of :func:`relative_linear_quality` for one task (``resource`` cancels out)."""
    return min(1.0, env.quality_at_uniform * env.n_types * (weight / load))


def relative_linear_full_quality_share(loads: np.ndarray, n_types: int, quality_at_uniform: float) -> np.ndarray:
    """The weight at which a type's quality reaches 1, for each type shared among ``loads`` instances."""
    return loads / (quality_at_uniform * n_types)


# ---- several resources: one effective (weight, resource) pair per atomic task -----------------------
#
# docs/model.md ("Several resources"). A child gives type ``t`` the weight ``w[r]`` of each resource ``r``;
# ``a[r]`` is its amount of ``r`` per unit of weight relative to the type's need, ``ar[r] / (f * R * need[r])``
# (:attr:`mgrao_core.world.World.resource_per_type`), so that ``x[r] = w[r] * a[r]`` is the resource given
# in units of "enough for the type's need". The combination makes one pair ``(w, a)`` from them, and the
# quality model is applied to it exactly as to the single resource (relative-linear reads ``w`` alone).
# ``shares[r]`` is each resource's share of the quality achieved: its output elasticity, ``d log x / d log
# x[r]``, which sums to 1 (``resource_credit = by-share``).

SCARCEST = 0
WEIGHTED = 1
RESOURCE_COMBINATION_CODES = {"scarcest": SCARCEST, "weighted": WEIGHTED}


def combine_resources(weights: np.ndarray, per_weight: np.ndarray, needs: np.ndarray,
                      combination: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The effective weight and resource of tasks, and each resource's share (numpy form; last axis the resource).

    ``scarcest``: the resource with the least ``x[r] = w[r] * a[r]`` (the first of ties) decides; its share is 1.
    ``weighted``: ``w = prod_r w[r] ** need[r]`` and ``a = prod_r a[r] ** need[r]`` (so ``w * a`` is the
    need-weighted geometric mean of the ``x[r]``, a Cobb-Douglas production), shares ``need[r]``.
    """
    weights, per_weight, needs = np.broadcast_arrays(np.asarray(weights, dtype=float), per_weight, needs)
    if combination == "scarcest":
        best = np.argmin(weights * per_weight, axis=-1)[..., None]
        shares = np.zeros(weights.shape)
        np.put_along_axis(shares, best, 1.0, axis=-1)
        return (np.take_along_axis(weights, best, -1)[..., 0], np.take_along_axis(per_weight, best, -1)[..., 0],
                shares)
    if combination != "weighted":
        raise ConfigError("resource_combination", f"unknown resource combination {combination!r}")
    w_eff = np.ones(weights.shape[:-1])
    a_eff = np.ones(weights.shape[:-1])
    for r in range(weights.shape[-1]):  # in the compiled form's order
        w_eff = w_eff * weights[..., r] ** needs[..., r]
        a_eff = a_eff * per_weight[..., r] ** needs[..., r]
    return w_eff, a_eff, needs.copy()


def combined_resources(weights, per_weight, needs, combination, shares):
    """Compiled form of :func:`combine_resources` for one task: returns ``(w, a)``, writes ``shares``.

    ``weights``, ``per_weight``, ``needs`` and ``shares`` have one entry per resource; ``combination`` is a
    code of :data:`RESOURCE_COMBINATION_CODES`.
    """
    n = weights.shape[0]
    if combination == WEIGHTED:
        w_eff = 1.0
        a_eff = 1.0
        for r in range(n):
            w_eff *= weights[r] ** needs[r]
            a_eff *= per_weight[r] ** needs[r]
            shares[r] = needs[r]
        return w_eff, a_eff
    best = 0
    least = weights[0] * per_weight[0]
    for r in range(1, n):
        x = weights[r] * per_weight[r]
        if x < least:
            least = x
            best = r
    for r in range(n):
        shares[r] = 0.0
    shares[best] = 1.0
    return weights[best], per_weight[best]


def single_split_resource(per_weight: np.ndarray, needs: np.ndarray, combination: str) -> np.ndarray:
    """``(n_children, n_types)``: the effective resource per unit of weight when one split serves every resource.

    ``per_weight (n_children, n_resources, n_types)``. With ``w[r] = w`` for every ``r``, scarcest's ``min_r w *
    a[r]`` is ``w * min_r a[r]`` and weighted's ``prod_r (w a[r]) ** need[r]`` is ``w * prod_r a[r] ** need[r]``
    (the needs sum to 1): one resource per type, which the oracle's water-filling takes as it takes ``ar / f``.
    """
    if combination == "scarcest":
        return per_weight.min(axis=1)
    out = np.ones((per_weight.shape[0], per_weight.shape[2]))
    for r in range(per_weight.shape[1]):
        out = out * per_weight[:, r, :] ** needs[None, :, r]
    return out


@functools.cache
def compiled_combined_resources() -> Any:
    """The compiled :func:`combined_resources`, numba's, inlined where it is called (numba loads here)."""
    import mgrao_core._numba_cache  # noqa: F401, I001  (before numba: picks its cache directory)
    from numba import njit

    return njit(inline="always")(combined_resources)


# ---- the registry ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class QualityModel:
    """One quality model: its name and kernel code, its three forms.

    Attributes:
        name: the ``quality_model`` parameter's value.
        code: the integer the kernel dispatches on (:func:`compiled_atomic_quality`).
        quality: numpy form ``(weight, resource, load, params)``, before the floor.
        task_quality: compiled form's source ``(weight, resource, load, env)``, one task, before the floor.
        weights_at_level: a concave model's inverse of the marginal value ``(values, per_weight, h, level)``
            (the oracle's water-filling); None for a linear one.
        full_quality_share: a linear model's weight of quality 1 ``(loads, n_types, quality_at_uniform)``
            (the oracle's knapsack); None for a concave one.
    """

    name: str
    code: int
    quality: Callable[[np.ndarray, float, np.ndarray | float, QualityParams], np.ndarray]
    task_quality: Callable[..., float]
    weights_at_level: Callable[[np.ndarray, np.ndarray, float, float], np.ndarray] | None = None
    full_quality_share: Callable[[np.ndarray, int, float], np.ndarray] | None = None

    def __post_init__(self) -> None:
        if (self.weights_at_level is None) == (self.full_quality_share is None):
            raise ValueError(f"quality model {self.name!r} needs exactly one of weights_at_level (concave) and "
                             "full_quality_share (linear), for the oracle")


QUALITY_MODELS: dict[str, QualityModel] = {
    model.name: model for model in (
        QualityModel("hyperbolic", HYPERBOLIC, _hyperbolic, hyperbolic_task_quality,
                     weights_at_level=hyperbolic_weights_at_level),
        QualityModel("exponential", EXPONENTIAL, _exponential, exponential_task_quality,
                     weights_at_level=exponential_weights_at_level),
        QualityModel("relative-linear", RELATIVE_LINEAR, _relative_linear, relative_linear_task_quality,
                     full_quality_share=relative_linear_full_quality_share),
    )
}
"""Every quality model by name, in the order the parameter schema offers them."""


def quality_model(name: str) -> QualityModel:
    """The registered model called ``name``.

    Raises:
        ConfigError: no model has that name (the error names it and the known ones).
    """
    model = QUALITY_MODELS.get(name)
    if model is None:
        raise ConfigError("quality_model", f"unknown quality model {name!r} (known: {', '.join(QUALITY_MODELS)})")
    return model


def atomic_quality(weight: np.ndarray, resource: float, params: QualityParams,
                   load: np.ndarray | float = 1.0) -> np.ndarray:
    """Atomic task quality under ``params.quality_model``, kept in ``[quality_floor, 1]``.

    Args:
        weight: ``w[tp]``, the share of the child's resource given to each task's type.
        resource: ``ar[c]``, the child's resource amount.
        params: the quality model, ``half_saturation``, ``quality_at_uniform`` and ``quality_floor``.
        load: instances of each task's type the child receives this episode (load sharing), or 1.

    Raises:
        ConfigError: ``params.quality_model`` is no registered model.
    """
    quality = quality_model(params.quality_model).quality(weight, resource, load, params)
    return np.clip(quality, params.quality_floor, 1.0)


@functools.cache
def compiled_atomic_quality() -> Any:
    """The compiled ``atomic_task_quality(weight, resource, load, env)``, numba's, inlined where it is called.

    Quality of one atomic task under the model whose code is ``env.quality_model``, at least
    ``env.quality_floor``; ``weight`` is the share of the child's resource ``resource`` given to the
    task's type, shared among ``load`` instances (1 without load sharing). An unknown code gives NaN
    (which the runner refuses as a non-finite utility), never another model's quality.

    numba is imported here, on the engine's first use, not with the schema. Each code has its own
    branch calling its model's compiled form; a new model adds its branch here.
    """
    import mgrao_core._numba_cache  # noqa: F401, I001  (before numba: picks its cache directory)
    from numba import njit

    inline = njit(inline="always")
    forms = {model.code: inline(model.task_quality) for model in QUALITY_MODELS.values()}
    hyperbolic, exponential, relative_linear = forms[HYPERBOLIC], forms[EXPONENTIAL], forms[RELATIVE_LINEAR]

    def atomic_task_quality(weight, resource, load, env):
        code = env.quality_model
        if code == HYPERBOLIC:
            quality = hyperbolic(weight, resource, load, env)
        elif code == EXPONENTIAL:
            quality = exponential(weight, resource, load, env)
        elif code == RELATIVE_LINEAR:
            quality = relative_linear(weight, resource, load, env)
        else:  # no model has this code
            return math.nan
        return max(quality, env.quality_floor)

    return inline(atomic_task_quality)
