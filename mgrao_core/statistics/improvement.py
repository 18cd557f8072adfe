"""P(X > Y) by counting: scores as integer codes, so that its bootstrap counts instead of ranking.

:func:`mgrao_core.statistics.metrics.probability_of_improvement` depends on the order of the scores alone; the
codes keep that order (:func:`improvement_codes`) and :func:`improvement_of_codes` computes it from how often
each code is drawn.
"""

from __future__ import annotations

import numpy as np


def improvement_codes(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """X's and Y's scores as the rank of their value among the distinct values of both, task by task.

    P(X > Y) depends on their order alone, so it is the same of the codes; counting codes is what makes its
    bootstrap fast (:func:`improvement_of_codes`). The codes are whole numbers held as floats, so that the
    cells a ragged matrix lacks stay NaN (and stay absent when the bootstrap resamples them).
    """
    codes_x, codes_y = np.full(x.shape, np.nan), np.full(y.shape, np.nan)
    width = 1
    for t in range(x.shape[-1]):
        px, py = ~np.isnan(x[:, t]), ~np.isnan(y[:, t])
        values, inverse = np.unique(np.concatenate([x[px, t], y[py, t]]), return_inverse=True)
        codes_x[px, t], codes_y[py, t] = inverse[: px.sum()], inverse[px.sum():]
        width = max(width, len(values))
    return codes_x, codes_y, width


def improvement_of_codes(codes_x: np.ndarray, codes_y: np.ndarray, width: int) -> np.ndarray:
    """:func:`mgrao_core.statistics.metrics.probability_of_improvement` of whole codes in ``[0, width)``, by counting.

    Per batch and task, ``U = sum over codes k of count_x[k] * (count_y below k + count_y[k] / 2)``, divided by
    the task's runs of X times its runs of Y; NaN codes (cells a ragged matrix lacks) count for nothing.
    """
    ragged = bool(np.isnan(codes_x).any() or np.isnan(codes_y).any())
    n_x, n_y = codes_x.shape[-2], codes_y.shape[-2]
    lead, tasks = codes_x.shape[:-2], codes_x.shape[-1]
    rows = int(np.prod(lead, dtype=np.int64)) * tasks
    columns = width + 1 if ragged else width  # the absent cells' column, dropped
    offset = (np.arange(rows, dtype=np.int64) * columns).reshape(*lead, 1, tasks)

    def counts(codes: np.ndarray) -> np.ndarray:
        whole = np.where(np.isnan(codes), width, codes).astype(np.int64) if ragged else codes.astype(np.int64)
        flat = (whole + offset).ravel()
        return np.bincount(flat, minlength=rows * columns).reshape(rows, columns)[:, :width].astype(float)

    cx, cy = counts(codes_x), counts(codes_y)
    below = np.cumsum(cy, axis=1) - cy
    u = np.sum(cx * (below + 0.5 * cy), axis=1).reshape(*lead, tasks)
    if ragged:
        n_x = cx.sum(axis=1).reshape(*lead, tasks)
        n_y = cy.sum(axis=1).reshape(*lead, tasks)
    return np.mean(u / (n_x * n_y), axis=-1)
