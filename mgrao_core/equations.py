"""The paper's equations, one small pure function each, named after the paper's terms.

These are the reference definitions: readable, dense and per child. The batched engine
(:mod:`mgrao_core.engine`) computes the same quantities lazily and is tested against them. The
resource allocation and the atomic task quality are defined in :mod:`mgrao_core.quality` (beside
their compiled forms) and named here too.
"""

from __future__ import annotations

import math

import numpy as np

from mgrao_core.quality import atomic_quality as atomic_quality
from mgrao_core.quality import exponential_quality as exponential_quality
from mgrao_core.quality import hyperbolic_quality as hyperbolic_quality
from mgrao_core.quality import relative_linear_quality as relative_linear_quality
from mgrao_core.quality import resource_amount as resource_amount


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


def blend_vector(weights: np.ndarray, counts: np.ndarray, use_counts: bool = True) -> np.ndarray:
    """Resource weights blending vector ``B = sumnorm(dkl) + sumnorm(count)``.

    Without ``use_counts`` (``group_blend = dkl-only``, not the paper's) ``B = sumnorm(dkl)``.
    """
    if not use_counts:
        return sumnorm(kl_to_uniform(weights))
    return sumnorm(kl_to_uniform(weights)) + sumnorm(counts)


def combined_weights(weights: np.ndarray, counts: np.ndarray, temperature: float,
                     use_counts: bool = True) -> np.ndarray:
    """Combined resource weights ``softmax(sumnorm(B) @ PW / temperature)`` (algorithm 2)."""
    return softmax(sumnorm(blend_vector(weights, counts, use_counts)) @ weights, temperature)


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


def task_share(learning_cost: float, learned: int, learned_by_max: int) -> float:
    """The share of a child's resources left for its tasks when learning takes its cost (docs/model.md).

    Learning ``learned`` numbers takes ``learning_cost * learned / learned_by_max`` of each resource, at most all
    of it: ``learned_by_max`` is what ``mgrao-max`` keeps (one model per parent, the paper's "unlimited"
    learning), which pays ``learning_cost`` itself. A child gives a task of type ``t`` the resource
    ``task_share * w[t] * ar`` instead of ``w[t] * ar``; a share of 1 (nothing learned, or no cost) changes nothing.
    """
    return 1.0 - min(1.0, learning_cost * learned / learned_by_max)


def need_amount(task_need: float, resource_mean: float, n_types: int) -> float:
    """The amount below which an atomic task fails: ``task_need`` times the mean child's uniform amount.

    The amount a task gets is what the quality model reads, ``x = w * a / load`` (with several resources, of the last
    resource relative to the type's need); the unit is what a uniform split gives a child of mean resource,
    ``resource_mean / n_types`` (docs/model.md, "Tasks that fail, and hierarchical allocation").
    """
    return task_need * resource_mean / n_types


def neighbour(child: int, i: int, n_children: int, ring: bool) -> int:
    """The ``i``-th child that ``child`` turns to for a task it cannot complete.

    Every other child from the next one on (``all``: ``child + 1, child + 2, ...``, ``n_children - 1`` of them), or
    the next and the previous one (``ring``: :func:`n_neighbours` says how many).
    """
    if ring and i == 1:
        return (child - 1) % n_children
    return (child + 1 + i) % n_children


def n_neighbours(n_children: int, ring: bool) -> int:
    """How many children a child can turn to (:func:`neighbour`)."""
    return min(2, n_children - 1) if ring else n_children - 1
