"""Aggregate metrics over a score matrix, as rliable defines them (Agarwal et al. 2021), docs/statistics.md.

Each metric is a pure function of a score matrix ``scores`` of shape ``(..., runs, tasks)``: ``scores[..., n, m]``
is run ``n``'s score on task ``m`` (here: a seed's normalised score on a system). Leading axes are batches (a
bootstrap's repetitions, the points of a curve): the metric is taken over the last two axes of each. On a
two-dimensional matrix each equals its namesake in ``rliable.metrics`` (the tests hold them to 1e-12):

* :func:`aggregate_mean`: the mean over tasks of each task's mean score;
* :func:`aggregate_median`: the median over tasks of each task's mean score;
* :func:`aggregate_iqm`: the interquartile mean, the 25% trimmed mean of every run of every task
  (``scipy.stats.trim_mean``: ``floor(N / 4)`` of the ``N`` scores cut from each end);
* :func:`aggregate_optimality_gap`: ``gamma`` minus the mean of every score clipped at ``gamma``;
* :func:`probability_of_improvement`: P(X > Y), each task's Mann-Whitney statistic ``U / (n_x n_y)`` (ties
  count one half) averaged over tasks;
* :func:`score_distribution`: the share of every run of every task whose score exceeds each ``tau`` (the
  performance profile).

How intervals are made is :mod:`mgrao_core.statistics.bootstrap`'s; the metrics do not know they are bootstrapped.
"""

from __future__ import annotations

import numpy as np

IQM_TRIM = 0.25
"""The share cut from each end for the interquartile mean."""
OPTIMALITY_GAMMA = 1.0
"""The threshold of the optimality gap: a score of 1 is the oracle's mean."""


def aggregate_mean(scores: np.ndarray) -> np.ndarray:
    """Mean over tasks of the per-task mean scores."""
    return np.mean(np.mean(scores, axis=-2), axis=-1)


def aggregate_median(scores: np.ndarray) -> np.ndarray:
    """Median over tasks of the per-task mean scores."""
    return np.median(np.mean(scores, axis=-2), axis=-1)


def aggregate_iqm(scores: np.ndarray) -> np.ndarray:
    """Interquartile mean: the 25% trimmed mean of all runs of all tasks together."""
    from scipy.stats import trim_mean

    flat = np.reshape(scores, (*np.shape(scores)[:-2], -1))
    return trim_mean(flat, proportiontocut=IQM_TRIM, axis=-1)


def aggregate_iqm_of_counts(scores: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """:func:`aggregate_iqm` of the resamples that hold each score ``counts[b, n, m]`` times (a bootstrap's draws).

    ``scores`` is ``(..., runs, tasks)``, ``counts`` ``(batch, runs, tasks)`` summing to ``runs * tasks`` in each
    batch; returns ``(batch, ...)``. In each resample's sorted order a score occupies the places from the
    counts before it to those up to it; its weight is how many of them lie between the ``floor(N / 4)`` cut
    from each end (``scipy.stats.trim_mean``'s cut), without sorting any resample.
    """
    lead = np.shape(scores)[:-2]
    flat = np.reshape(scores, (*lead, -1))
    total = flat.shape[-1]
    cut = int(IQM_TRIM * total)
    order = np.argsort(flat, axis=-1, kind="stable")
    ordered = np.take_along_axis(flat, order, axis=-1)
    drawn = np.reshape(counts, (np.shape(counts)[0], total)).astype(np.int32)
    out = np.empty((drawn.shape[0], *lead))
    for point in np.ndindex(*lead):  # each point of a curve (none for a matrix): (batch, N) at a time
        placed = drawn[:, order[point]]
        upto = np.cumsum(placed, axis=1, dtype=np.int32)  # places up to each score in the resample's order
        below = upto - placed  # places before it
        np.minimum(upto, total - cut, out=upto)
        np.maximum(below, cut, out=below)
        upto -= below
        np.maximum(upto, 0, out=upto)  # its places inside the kept middle
        out[(slice(None), *point)] = upto.astype(np.float64) @ ordered[point]
    return out / (total - 2 * cut)


def aggregate_optimality_gap(scores: np.ndarray, gamma: float = OPTIMALITY_GAMMA) -> np.ndarray:
    """``gamma`` minus the mean of all scores clipped from above at ``gamma``: how far below the target it falls."""
    return gamma - np.mean(np.minimum(scores, gamma), axis=(-2, -1))


AGGREGATES = {"mean": aggregate_mean, "median": aggregate_median, "iqm": aggregate_iqm,
              "optimality_gap": aggregate_optimality_gap}
"""The aggregate metrics by the name the answers give them, in the order they are shown."""


def all_aggregates(scores: np.ndarray) -> np.ndarray:
    """Every metric of :data:`AGGREGATES`, stacked on a last axis (in that order)."""
    return np.stack([metric(scores) for metric in AGGREGATES.values()], axis=-1)


def score_distribution(scores: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """The performance profile: for each ``tau``, the share of all runs of all tasks with a score above it.

    Returns ``(..., len(taus))``.
    """
    taus = np.asarray(taus, dtype=float)
    flat = np.reshape(scores, (-1, np.shape(scores)[-2] * np.shape(scores)[-1]))
    # a score is above taus[j] exactly for the j below the count of taus under it
    under = np.searchsorted(taus, flat, side="left") + (np.arange(len(flat)) * (len(taus) + 1))[:, None]
    counts = np.bincount(under.ravel(), minlength=len(flat) * (len(taus) + 1)).reshape(len(flat), len(taus) + 1)
    above = np.cumsum(counts[:, ::-1], axis=1)[:, ::-1][:, 1:] / flat.shape[1]
    return above.reshape(*np.shape(scores)[:-2], len(taus))


def probability_of_improvement(scores_x: np.ndarray, scores_y: np.ndarray) -> np.ndarray:
    """P(X > Y): each task's Mann-Whitney ``U / (n_x n_y)`` (ties count 1/2), averaged over tasks.

    ``scores_x`` is ``(..., n_x, tasks)``, ``scores_y`` ``(..., n_y, tasks)`` with the same leading axes. ``U`` is
    the sum of X's ranks among both samples (tied values sharing the mean of their ranks, as
    ``scipy.stats.mannwhitneyu``) less ``n_x (n_x + 1) / 2``.
    """
    n_x, n_y = np.shape(scores_x)[-2], np.shape(scores_y)[-2]
    both = np.ascontiguousarray(np.swapaxes(np.concatenate([scores_x, scores_y], axis=-2), -2, -1))
    order = np.argsort(both, axis=-1)
    ordered = np.take_along_axis(both, order, axis=-1)
    rank_sum = np.sum(np.where(order < n_x, _mean_ranks_of_sorted(ordered), 0.0), axis=-1)
    return np.mean((rank_sum - n_x * (n_x + 1) / 2.0) / (n_x * n_y), axis=-1)


def _mean_ranks_of_sorted(ordered: np.ndarray) -> np.ndarray:
    """The rank from 1 of each place of rows sorted along the last axis, tied values sharing the mean of theirs.

    A tied run spanning places ``start .. end`` has the mean rank ``(start + end) / 2 + 1``.
    """
    count = ordered.shape[-1]
    position = np.broadcast_to(np.arange(count, dtype=float), ordered.shape)
    first = np.ones(ordered.shape, dtype=bool)
    first[..., 1:] = ordered[..., 1:] != ordered[..., :-1]
    if first.all():  # no ties
        return position + 1.0
    last = np.ones(ordered.shape, dtype=bool)
    last[..., :-1] = first[..., 1:]
    start = np.maximum.accumulate(np.where(first, position, 0.0), axis=-1)
    end = np.flip(np.minimum.accumulate(np.flip(np.where(last, position, count - 1.0), axis=-1), axis=-1), axis=-1)
    return (start + end) / 2.0 + 1.0
