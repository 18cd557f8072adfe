"""Student's t interval of a mean: the quantile of whole degrees of freedom solved exactly, and ``mean_ci95``.

The t quantiles of whole degrees of freedom are computed here exactly; scipy (its tests, and any other
quantile) is imported on first use, so that importing the core (a worker's start) does not load it.
"""

from __future__ import annotations

import math
import sys
from statistics import NormalDist

import numpy as np

CONFIDENCE = 0.95
"""The level of every interval the core gives (two-sided)."""


SERIES_DOF = 1000
"""Most degrees of freedom :func:`t_quantile` solves from the series (its ``dof / 2`` terms' rounding
grows with them: 3e-13 relative at 1,000, 3e-11 at 100,000); beyond, scipy's ``stdtrit``."""


def _t_within(t: float, dof: int) -> float:
    """``P(-t < T < t)`` for Student's t with a whole number ``dof`` of degrees of freedom, exactly.

    Abramowitz and Stegun 26.7.3 (odd ``dof``) and 26.7.4 (even): with ``theta = atan(t / sqrt(dof))``,
    a finite series in ``cos(theta)`` of ``dof / 2`` terms.
    """
    theta = math.atan(t / math.sqrt(dof))
    c2 = math.cos(theta) ** 2
    if dof % 2:  # (2/pi) (theta + sin cos (1 + 2/3 cos^2 + 2*4/(3*5) cos^4 + ...)), the series up to cos^(dof-3)
        ratios = np.arange(2, dof - 1, 2, dtype=float) / np.arange(3, dof, 2, dtype=float) * c2
        series = 1.0 + float(np.cumprod(ratios).sum())
        return 2.0 / math.pi * (theta + math.sin(theta) * math.cos(theta) * series)
    ratios = np.arange(1, dof - 1, 2, dtype=float) / np.arange(2, dof, 2, dtype=float) * c2  # 1 + 1/2 cos^2 + ...
    return math.sin(theta) * (1.0 + float(np.cumprod(ratios).sum()))


def _t_quantile_whole(dof: int, confidence: float) -> float:
    """The ``t`` with ``P(-t < T < t) = confidence``, by Newton's method on :func:`_t_within`.

    That function is concave for ``t > 0``, so every iterate is below the root and rises to it (the
    start, the normal quantile, is below it already: t's tails are heavier), until rounding makes a
    step no longer positive (within about 1e-13 of the root): there it stops.
    """
    if not 0.0 < confidence < 1.0:
        return math.inf if confidence == 1.0 else 0.0 if confidence == 0.0 else math.nan
    if dof == 1:
        return math.tan(math.pi * confidence / 2)
    if dof == 2:
        return confidence * math.sqrt(2.0 / (1.0 - confidence * confidence))
    log_density = math.lgamma((dof + 1) / 2) - math.lgamma(dof / 2) - 0.5 * math.log(dof * math.pi)
    t = NormalDist().inv_cdf(0.5 + confidence / 2)
    for _ in range(100):
        density = math.exp(log_density - (dof + 1) / 2 * math.log1p(t * t / dof))
        step = (confidence - _t_within(t, dof)) / (2.0 * density)
        t += step
        if step <= 4 * sys.float_info.epsilon * t:
            break
    return t


def t_quantile(dof: int | np.ndarray, confidence: float = CONFIDENCE) -> float | np.ndarray:
    """The two-sided ``confidence`` quantile of Student's t with ``dof`` degrees of freedom (NaN below 1).

    ``t_quantile(9)`` is 2.2622. Whole degrees of freedom up to :data:`SERIES_DOF` (every interval
    here is on ``n - 1``) are solved from the distribution function's finite series (:func:`_t_within`),
    within 1e-12 of scipy's ``stdtrit`` (tests/core/test_stats.py); others go to scipy, whose 0.2 s
    import a command's summaries (``mgrao reproduce``) thus do without.
    """
    dofs = np.asarray(dof, dtype=float)
    flat = dofs.ravel()
    value = np.full(flat.shape, math.nan)
    for i, d in enumerate(flat):
        if 1 <= d <= SERIES_DOF and d == math.floor(d):
            value[i] = _t_quantile_whole(int(d), confidence)
        elif d >= 1:
            from scipy.special import stdtrit  # only for a fractional (or huge) number of degrees of freedom

            value[i] = stdtrit(d, 0.5 + confidence / 2)
    return float(value[0]) if dofs.ndim == 0 else value.reshape(dofs.shape)


def mean_interval(samples: np.ndarray, confidence: float = CONFIDENCE) -> tuple[float, float, float]:
    """Mean and its ``confidence`` t-interval ``(mean, low, high)``; the interval is NaN for one sample."""
    samples = np.asarray(samples, dtype=float)
    mean = float(samples.mean())
    if samples.size < 2:
        return mean, math.nan, math.nan
    half = t_quantile(samples.size - 1, confidence) * float(samples.std(ddof=1)) / math.sqrt(samples.size)
    return mean, mean - half, mean + half


def mean_ci95(samples: np.ndarray) -> tuple[float, float, float]:
    """Mean and 95% t-interval ``(mean, low, high)``; the interval is NaN for one sample."""
    return mean_interval(samples, CONFIDENCE)
