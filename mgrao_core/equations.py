"""The paper's equations, one small pure function each, named after the paper's terms.

These are the reference definitions: readable, dense and per child. The batched engine
(:mod:`mgrao_core.engine`) computes the same quantities lazily and is tested against them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from mgrao_core.params import SystemParams


def sumnorm(x: np.ndarray, axis: int = -1) -> np.ndarray:
    """Sum-normalisation (paper footnote); an all-zero vector becomes the uniform vector."""
    x = np.asarray(x, dtype=float)
    total = x.sum(axis=axis, keepdims=True)
    uniform = np.full_like(x, 1.0 / x.shape[axis])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, x / np.where(total > 0, total, 1.0), uniform)


def softmax(x: np.ndarray, temperature: float = 1.0) -> np.ndarray:
    """Softmax normalisation (paper footnote) of ``x / temperature``."""
    z = np.asarray(x, dtype=float) / temperature
    z = np.exp(z - z.max())
    return z / z.sum()


def eligibility_update(trace: np.ndarray, group: int, task_type: int, decay: float) -> np.ndarray:
    """Replacing eligibility trace update (paper equation ``etu``).

    The entry ``(group, task_type)`` becomes 1; every other positive entry is multiplied by
    ``decay``; zero entries stay zero.
    """
    updated = np.where(trace > 0, trace * decay, 0.0)
    updated[group, task_type] = 1.0
    return updated


def pw_update(weights: np.ndarray, trace: np.ndarray, value: float, learning_rate: float) -> np.ndarray:
    """Algorithm 1, last two lines: ``PW + alpha * atv * E``, then sum-normalise each row."""
    return sumnorm(weights + learning_rate * value * trace, axis=1)


def kl_to_uniform(weights: np.ndarray) -> np.ndarray:
    """Parent group weights entropy: ``dkl[i] = sum_j PW[i,j] log(PW[i,j] * n)`` per row.

    Zero weights contribute zero (the limit of ``x log x``); rounding can never make it negative.
    """
    n = weights.shape[-1]
    with np.errstate(divide="ignore", invalid="ignore"):
        terms = np.where(weights > 0, weights * np.log(weights * n), 0.0)
    return np.maximum(terms.sum(axis=-1), 0.0)


def blend_vector(weights: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Resource weights blending vector ``B = sumnorm(dkl) + sumnorm(count)``."""
    return sumnorm(kl_to_uniform(weights)) + sumnorm(counts)


def combined_weights(weights: np.ndarray, counts: np.ndarray, temperature: float) -> np.ndarray:
    """Combined resource weights ``softmax(sumnorm(B) @ PW / temperature)`` (algorithm 2)."""
    return softmax(sumnorm(blend_vector(weights, counts)) @ weights, temperature)


def resource_amount(weight: np.ndarray, resource: float, load: np.ndarray | float = 1.0) -> np.ndarray:
    """Agent resource allocation ``x = w[tp] * ar[c]`` (paper definition), per instance of the type.

    ``load`` is the number of instances of the type the child receives in the episode when
    ``load_sharing`` is on (the resource is shared among them), 1 otherwise.
    """
    return np.asarray(weight, dtype=float) * resource / load


def hyperbolic_quality(x: np.ndarray, half_saturation: float) -> np.ndarray:
    """``q = x / (x + h)``: 0 without resource, 1/2 at ``x = h``, saturating towards 1."""
    return x / (x + half_saturation)


def exponential_quality(x: np.ndarray, half_saturation: float) -> np.ndarray:
    """``q = 1 - exp(-x / h)`` (computed as ``-expm1(-x / h)``)."""
    return -np.expm1(-x / half_saturation)


def relative_linear_quality(weight: np.ndarray, n_types: int, quality_at_uniform: float,
                            load: np.ndarray | float = 1.0) -> np.ndarray:
    """``q = min(1, quality_at_uniform * x / (ar / n_types))``: the first reading.

    That is ``quality_at_uniform * n_types * w[tp]`` capped at 1: the child's own resource ``ar``
    cancels out.
    """
    return np.minimum(1.0, quality_at_uniform * n_types * (np.asarray(weight, dtype=float) / load))


def atomic_quality(weight: np.ndarray, resource: float, params: SystemParams,
                   load: np.ndarray | float = 1.0) -> np.ndarray:
    """Atomic task quality under ``params.quality_model``, kept in ``[quality_floor, 1]``.

    Args:
        weight: ``w[tp]``, the share of the child's resource given to each task's type.
        resource: ``ar[c]``, the child's resource amount.
        params: the quality model, ``half_saturation``, ``quality_at_uniform`` and ``quality_floor``.
        load: instances of each task's type the child receives this episode (load sharing), or 1.
    """
    if params.quality_model == "relative-linear":
        quality = relative_linear_quality(weight, params.n_types, params.quality_at_uniform, load)
    else:
        x = resource_amount(weight, resource, load)
        if params.quality_model == "hyperbolic":
            quality = hyperbolic_quality(x, params.half_saturation)
        else:
            quality = exponential_quality(x, params.half_saturation)
    return np.clip(quality, params.quality_floor, 1.0)


def proportional_values(profile: np.ndarray, noise: np.ndarray, value_noise: float) -> np.ndarray:
    """Component tasks proportional values ``ctv = sumnorm(profile * exp(value_noise * N))``.

    Summed left to right (as the engine does), so that both give the same bits.
    """
    raw = np.asarray(profile, dtype=float) * np.array([math.exp(value_noise * z) for z in np.ravel(noise)])
    return raw / sum(raw.tolist())


def composite_quality(ctv: np.ndarray, quality: np.ndarray) -> float:
    """Composite task quality ``taq = sum(ctv * q)``, summed left to right."""
    return float(sum((np.asarray(ctv) * np.asarray(quality)).tolist()))


def absolute_values(ctv: np.ndarray, taq: float) -> np.ndarray:
    """Component tasks absolute values ``atv = taq * ctv``."""
    return taq * ctv
