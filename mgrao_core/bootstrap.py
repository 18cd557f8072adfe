"""The stratified bootstrap every interval of a comparison goes through (docs/statistics.md, "Intervals").

As rliable's ``StratifiedBootstrap`` (one score matrix) and ``StratifiedIndependentBootstrap`` (several):
each matrix ``(..., runs, tasks)`` is resampled run by run *within each task* (a task's seeds are drawn
with replacement from that task's own, every task keeping its count), each matrix independently of the
others, and the interval is the percentile interval of the statistic over the repetitions. The resampling
is scipy's (``scipy.stats.bootstrap`` with each task's column as a sample of its own, ``paired=False``,
``method="percentile"``); leading axes of a matrix (the points of a curve) share each repetition's draw.

A repetition's draws come from a generator seeded with the answer's ``seed`` and the names of what is
resampled (:func:`generator`), so the same data, seed and repetitions give the same interval, and adding a
configuration to a comparison leaves the others' intervals as they were.
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from mgrao_core.stats import CONFIDENCE

DEFAULT_REPETITIONS = 2000
"""Repetitions of a comparison's bootstrap unless asked otherwise (the CLI's tables take 10,000)."""
MAX_REPETITIONS = 50_000
"""The most repetitions an answer may ask for (rliable's default for interval estimates)."""
BATCH_VALUES = 2_000_000
"""Resampled scores held at once: repetitions are drawn in batches of at most this many values."""


class Interval(NamedTuple):
    """A statistic's point estimate and its percentile interval, arrays of the statistic's shape."""

    estimate: np.ndarray
    low: np.ndarray
    high: np.ndarray


def generator(seed: int, *names: str) -> np.random.Generator:
    """The generator of one bootstrap: seeded by ``seed`` and the names of what it resamples."""
    return np.random.default_rng([seed, *(zlib.crc32(name.encode()) for name in names)])


def stratified_bootstrap(statistic: Callable[..., np.ndarray], *matrices: np.ndarray, repetitions: int,
                         rng: np.random.Generator, confidence: float = CONFIDENCE) -> Interval:
    """``statistic(*matrices)`` with its percentile interval from resampling runs within each task.

    Args:
        statistic: a function of matrices ``(..., runs, tasks)`` (with any leading batch axes) returning an
            array ``(..., *shape)``; it is called on the data itself and on ``(..., batch, runs, tasks)``
            resamples.
        matrices: score matrices; each is resampled on its own.
        repetitions: bootstrap repetitions.
        rng: the draws' generator (:func:`generator`).
        confidence: the interval's level (two-sided).

    Returns:
        The estimate and the interval's ends, each shaped as the statistic of the data.
    """
    from scipy.stats import bootstrap

    tasks = [m.shape[-1] for m in matrices]
    lead = matrices[0].ndim - 2
    columns = [np.ascontiguousarray(m[..., t]) for m in matrices for t in range(m.shape[-1])]

    def of_columns(*resampled: np.ndarray, axis: int = -1) -> np.ndarray:
        # each column arrives as (..., batch, runs): stack them back into matrices (..., batch, runs, tasks)
        parts, start = [], 0
        for count in tasks:
            parts.append(np.stack(resampled[start:start + count], axis=-1))
            start += count
        return np.moveaxis(statistic(*parts), lead, -1)  # scipy wants the repetitions last

    values = sum(m.size for m in matrices)
    result = bootstrap(columns, of_columns, n_resamples=repetitions, batch=max(1, BATCH_VALUES // values),
                       vectorized=True, paired=False, axis=-1, confidence_level=confidence, method="percentile",
                       rng=rng)
    estimate = np.asarray(statistic(*matrices), dtype=float)
    return Interval(estimate, np.asarray(result.confidence_interval.low, dtype=float),
                    np.asarray(result.confidence_interval.high, dtype=float))
