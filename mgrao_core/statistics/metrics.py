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

**Ragged matrices.** Systems may keep different numbers of seeds (a job stopped by a rule, a run logged on
other seeds): such a matrix pads each task's runs with NaN below its count, its present runs first. Every
metric then weighs each *task* equally, each run of a task ``1 / (tasks * runs of that task)``: the mean,
median, optimality gap and profile are means over tasks of per-task figures, P(X > Y) is each task's
Mann-Whitney statistic on its own counts, and the IQM is the weighted 25% trimmed mean (the scores' weights
cut from each end: ``floor(N / 4) / N`` of the total, ``N`` the scores present). On a matrix without NaN each
is exactly its rectangular namesake above, the code unchanged.

How intervals are made is :mod:`mgrao_core.statistics.bootstrap`'s; the metrics do not know they are bootstrapped.
"""

from __future__ import annotations

import numpy as np

IQM_TRIM = 0.25
"""The share cut from each end for the interquartile mean."""
OPTIMALITY_GAMMA = 1.0
"""The threshold of the optimality gap: a score of 1 is the oracle's mean."""


def is_ragged(scores: np.ndarray) -> bool:
    """Whether some task lacks some runs (NaN cells: the module's "Ragged matrices")."""
    return bool(np.isnan(scores).any())


def present_counts(scores: np.ndarray) -> np.ndarray:
    """Each task's runs present, ``(..., tasks)``."""
    return np.sum(~np.isnan(scores), axis=-2)


def _task_means(scores: np.ndarray) -> np.ndarray:
    """Each task's mean over its present runs, ``(..., tasks)``."""
    if not is_ragged(scores):
        return np.mean(scores, axis=-2)
    return np.nansum(scores, axis=-2) / present_counts(scores)


def aggregate_mean(scores: np.ndarray) -> np.ndarray:
    """Mean over tasks of the per-task mean scores."""
    return np.mean(_task_means(scores), axis=-1)


def aggregate_median(scores: np.ndarray) -> np.ndarray:
    """Median over tasks of the per-task mean scores."""
    return np.median(_task_means(scores), axis=-1)


def run_weights(scores: np.ndarray) -> np.ndarray:
    """Each cell's weight, every task weighing the same: ``1 / (tasks * runs present of its task)``, 0 where absent."""
    present = ~np.isnan(scores)
    counts = np.sum(present, axis=-2, keepdims=True)
    return np.where(present, 1.0 / (np.shape(scores)[-1] * np.maximum(counts, 1)), 0.0)


def _trimmed_of_masses(ordered: np.ndarray, masses: np.ndarray, cut: np.ndarray) -> np.ndarray:
    """The mean of sorted values (last axis) of weights ``masses`` (summing to 1), ``cut`` cut from each end.

    A value's weight lies between the weights before it and those up to it; what of it lies inside
    ``[cut, 1 - cut]`` is kept.
    """
    upto = np.cumsum(masses, axis=-1)
    below = upto - masses
    low, high = cut[..., None], 1.0 - cut[..., None]
    kept = np.clip(upto, low, high) - np.clip(below, low, high)
    return np.sum(kept * np.where(masses > 0, ordered, 0.0), axis=-1) / (1.0 - 2.0 * cut)


def _iqm_cut(present: np.ndarray) -> np.ndarray:
    """The weight cut from each end: ``floor(N / 4) / N`` of ``N`` scores present (scipy's cut of equal weights)."""
    total = present.reshape(*present.shape[:-2], -1).sum(axis=-1)
    return np.floor(IQM_TRIM * total) / total


def aggregate_iqm(scores: np.ndarray) -> np.ndarray:
    """Interquartile mean: the 25% trimmed mean of all runs of all tasks together (ragged: weighted, module docs)."""
    if is_ragged(scores):
        lead = np.shape(scores)[:-2]
        flat = np.reshape(scores, (*lead, -1))
        weights = np.reshape(run_weights(scores), (*lead, -1))
        order = np.argsort(flat, axis=-1, kind="stable")  # NaN (weight 0) last
        return _trimmed_of_masses(np.take_along_axis(flat, order, axis=-1),
                                  np.take_along_axis(weights, order, axis=-1), _iqm_cut(~np.isnan(scores)))
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


def aggregate_iqm_of_weighted_counts(scores: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """:func:`aggregate_iqm_of_counts` of a ragged matrix: each drawn score weighs ``1 / (tasks * runs of its task)``.

    ``counts[b, n, m]`` is 0 in the cells a task lacks (NaN); returns ``(batch, ...)``.
    """
    lead = np.shape(scores)[:-2]
    flat = np.reshape(scores, (*lead, -1))
    weights = np.reshape(run_weights(scores), (*lead, -1))
    cut = _iqm_cut(~np.isnan(scores))
    order = np.argsort(flat, axis=-1, kind="stable")
    ordered = np.take_along_axis(flat, order, axis=-1)
    drawn = np.reshape(counts, (np.shape(counts)[0], -1)).astype(np.float64)
    out = np.empty((drawn.shape[0], *lead))
    for point in np.ndindex(*lead):
        masses = drawn[:, order[point]] * np.take_along_axis(weights[point], order[point], axis=-1)
        out[(slice(None), *point)] = _trimmed_of_masses(ordered[point], masses, np.broadcast_to(cut[point],
                                                                                                 (len(drawn),)))
    return out


def aggregate_optimality_gap(scores: np.ndarray, gamma: float = OPTIMALITY_GAMMA) -> np.ndarray:
    """``gamma`` minus the mean of all scores clipped from above at ``gamma``: how far below the target it falls."""
    if is_ragged(scores):
        return gamma - np.mean(_task_means(np.minimum(scores, gamma)), axis=-1)
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
    if is_ragged(scores):  # each task's share above tau (NaN is above none), averaged over tasks
        above = np.sum(np.asarray(scores)[..., None] > taus, axis=-3) / present_counts(scores)[..., None]
        return np.mean(above, axis=-2)
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
    if is_ragged(scores_x) or is_ragged(scores_y):  # each task on its own runs present
        per_task = [probability_of_improvement(_present(scores_x[..., t]), _present(scores_y[..., t]))
                    for t in range(np.shape(scores_x)[-1])]
        return np.mean(per_task, axis=0)
    n_x, n_y = np.shape(scores_x)[-2], np.shape(scores_y)[-2]
    both = np.ascontiguousarray(np.swapaxes(np.concatenate([scores_x, scores_y], axis=-2), -2, -1))
    order = np.argsort(both, axis=-1)
    ordered = np.take_along_axis(both, order, axis=-1)
    rank_sum = np.sum(np.where(order < n_x, _mean_ranks_of_sorted(ordered), 0.0), axis=-1)
    return np.mean((rank_sum - n_x * (n_x + 1) / 2.0) / (n_x * n_y), axis=-1)


def _present(column: np.ndarray) -> np.ndarray:
    """One task's present runs as a one-task matrix ``(runs, 1)`` (two-dimensional only)."""
    if column.ndim != 1:
        raise ValueError("a ragged P(X > Y) is taken on two-dimensional matrices")
    return column[~np.isnan(column)][:, None]


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
