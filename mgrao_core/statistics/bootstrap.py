"""The stratified bootstrap every interval of a comparison goes through (docs/statistics.md, "Intervals").

As rliable's ``StratifiedBootstrap`` (one score matrix) and ``StratifiedIndependentBootstrap`` (several):
each matrix ``(..., runs, tasks)`` is resampled run by run *within each task* (every cell of a repetition
draws one of its task's runs, with replacement: ``rliable.library.StratifiedBootstrap.update_indices``), each
matrix independently of the others, and the interval is the percentile interval of the statistic over the
repetitions (``numpy.percentile``, linear, as scipy's and arch's percentile intervals). Leading axes of a
matrix (the points of a curve) share each repetition's draw: a repetition is a set of seeds.

A repetition's draws come from a generator seeded with the answer's ``seed`` and the names of what is
resampled (:func:`generator`), so the same data, seed and repetitions give the same interval, and adding a
configuration to a comparison leaves the others' draws as they were (their intervals too, unless it narrows
the seeds every aggregated configuration shares).
"""

from __future__ import annotations

import zlib
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from mgrao_core.statistics.student import CONFIDENCE

DEFAULT_REPETITIONS = 2000
"""Repetitions of a comparison's bootstrap unless asked otherwise (the CLI's tables take 10,000)."""
MAX_REPETITIONS = 50_000
"""The most repetitions an answer may ask for (rliable's default for interval estimates)."""
BATCH_VALUES = 4_000_000
"""Resampled scores held at once: repetitions are drawn in batches of at most this many values."""


class Interval(NamedTuple):
    """A statistic's point estimate and its percentile interval, arrays of the statistic's shape."""

    estimate: np.ndarray
    low: np.ndarray
    high: np.ndarray


def generator(seed: int, *names: str) -> np.random.Generator:
    """The generator of one bootstrap: seeded by ``seed`` and the names of what it resamples."""
    return np.random.default_rng([seed, *(zlib.crc32(name.encode()) for name in names)])


def draws(rng: np.random.Generator, repetitions: int, runs: int, tasks: int) -> np.ndarray:
    """``(repetitions, runs, tasks)`` run indices: each cell one of its task's ``runs``, with replacement."""
    return rng.integers(0, runs, size=(repetitions, runs, tasks))


def ragged_draws(rng: np.random.Generator, repetitions: int, counts: np.ndarray, runs: int) -> np.ndarray:
    """:func:`draws` of a ragged matrix: task ``m``'s first ``counts[m]`` cells each one of its ``counts[m]`` runs.

    The cells a task lacks point at its first absent run (NaN), so that they stay absent in every resample.
    """
    out = np.empty((repetitions, runs, len(counts)), dtype=np.int64)
    for task, count in enumerate(counts.tolist()):
        out[:, :count, task] = rng.integers(0, count, size=(repetitions, count))
        out[:, count:, task] = min(count, runs - 1)
    return out


def _draws_of(rng: np.random.Generator, repetitions: int, matrix: np.ndarray) -> np.ndarray:
    """The draws of one matrix: rectangular as :func:`draws` (rliable's), ragged as :func:`ragged_draws`."""
    absent = np.isnan(matrix)
    if not absent.any():
        return draws(rng, repetitions, matrix.shape[-2], matrix.shape[-1])
    present = ~absent.reshape(-1, *matrix.shape[-2:])[0]
    return ragged_draws(rng, repetitions, present.sum(axis=0), matrix.shape[-2])


def counts_of(indices: np.ndarray) -> np.ndarray:
    """How often each run of each task is drawn: ``(repetitions, runs, tasks)`` from :func:`draws`' indices."""
    repetitions, runs, tasks = indices.shape
    flat = indices + runs * (np.arange(repetitions)[:, None, None] * tasks + np.arange(tasks)[None, None, :])
    counts = np.bincount(flat.ravel(), minlength=repetitions * tasks * runs).reshape(repetitions, tasks, runs)
    return np.swapaxes(counts, 1, 2)


def stratified_bootstrap(statistic: Callable[..., np.ndarray], *matrices: np.ndarray, repetitions: int,
                         rng: np.random.Generator, confidence: float = CONFIDENCE,
                         of_counts: Callable[..., np.ndarray] | None = None) -> Interval:
    """``statistic(*matrices)`` with its percentile interval from resampling runs within each task.

    Args:
        statistic: a function of matrices ``(..., runs, tasks)`` returning an array ``(..., *shape)``; it makes
            the estimate, and unless ``of_counts`` is given, each repetition's value from the matrices resampled
            (``(batch, ..., runs, tasks)``, giving ``(batch, ..., *shape)``).
        matrices: score matrices; each is resampled on its own. A ragged one (NaN below a task's runs, as
            :mod:`mgrao_core.statistics.metrics` lays it out) resamples each task among its own runs, the
            absent cells staying absent (the NaN pattern of a matrix is the same along its leading axes).
        repetitions: bootstrap repetitions.
        rng: the draws' generator (:func:`generator`).
        confidence: the interval's level (two-sided).
        of_counts: optionally, the statistic of the matrices as the repetitions resample them, given instead as
            how often each run is drawn (``of_counts(*matrices, counts)``, ``counts`` one ``(batch, runs, tasks)``
            array per matrix, giving ``(batch, ..., *shape)``): the same statistic, cheaper where it sorts.

    Returns:
        The estimate and the interval's ends, each shaped as the statistic of the data.
    """
    estimate = np.asarray(statistic(*matrices), dtype=float)
    per_repetition = sum(m.size for m in matrices)
    batch = max(1, BATCH_VALUES // max(1, per_repetition))
    values = []
    for start in range(0, repetitions, batch):
        size = min(batch, repetitions - start)
        chosen = [_draws_of(rng, size, m) for m in matrices]
        if of_counts is not None:
            counts = [np.where(np.isnan(m.reshape(-1, *m.shape[-2:])[0]), 0, counts_of(c))
                      for m, c in zip(matrices, chosen, strict=True)]
            values.append(np.asarray(of_counts(*matrices, counts), dtype=float))
            continue
        resampled = []
        for m, indices in zip(matrices, chosen, strict=True):
            taken = m[..., indices, np.arange(m.shape[-1])]  # (..., batch, runs, tasks)
            resampled.append(np.moveaxis(taken, m.ndim - 2, 0))
        values.append(np.asarray(statistic(*resampled), dtype=float))
    tail = 100 * (1 - confidence) / 2
    low, high = np.percentile(np.concatenate(values, axis=0), [tail, 100 - tail], axis=0)
    return Interval(estimate, low, high)
