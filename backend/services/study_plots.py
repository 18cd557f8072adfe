"""What the study view plots, aggregated and downsampled on the server.

The browser receives at most a few thousand numbers per plot, however many trials a study has:

* ``history``: the best objective so far after each trial (at most :data:`MAX_POINTS` points,
  always keeping every point where the best improved);
* ``importance``: per dimension, the share of the objective's variance explained by that dimension
  alone (the correlation ratio eta squared over the dimension's values or quantile bins), and how often
  the trials' objectives shuffled over their values explain as much (``p_value``, a permutation test of
  :data:`PERMUTATIONS` shuffles, seeded): with few trials per value, eta squared is large whatever the
  parameter does (4 trials of 4 values: 1.00), and the test says so;
* ``slices``: per dimension, the objective of each trial against the dimension's value with the
  trial's own 95% interval over seeds (at most :data:`MAX_POINTS` trials, best first), and the mean
  per value or bin with its 95% interval over trials;
* ``heatmap``: the mean objective over two dimensions (their values or :data:`BINS` bins each);
* ``parallel``: parallel coordinates of at most :data:`MAX_POINTS` trials (the best, then an even
  spread of the rest).
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.services.studies import get_study, plan_of
from backend.store.models import SUCCEEDED, Trial
from mgrao_core.statistics.student import t_quantile

MAX_POINTS = 1000
BINS = 12
PERMUTATIONS = 499
"""Shuffles of a permutation test of eta squared (its p-value is at least 1 / 500)."""
PERMUTED_TRIALS = 1000
"""Trials a permutation test takes at most (an even spread of them), so that it stays fast."""


def permuted(values: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The trials a permutation test takes (their indices) and :data:`PERMUTATIONS` shuffles of their objectives.

    Seeded, so that the same study answers the same; shared by every dimension's test.
    """
    keep = np.arange(values.size)
    if values.size > PERMUTED_TRIALS:
        keep = np.linspace(0, values.size - 1, PERMUTED_TRIALS).round().astype(int)
    rng = np.random.default_rng(seed)
    return keep, np.array([rng.permutation(values[keep]) for _ in range(PERMUTATIONS)])


def eta_squared_p_value(values: np.ndarray, groups: np.ndarray, shuffles: tuple[np.ndarray, np.ndarray]) -> float:
    """How often shuffled objectives explain as much variance as ``values`` do over ``groups`` (eta squared).

    ``(1 + #{shuffles at least as large}) / (1 + PERMUTATIONS)``: near 1 where the grouping explains no more than
    chance would with these trials (every trial its own group: always 1), small where it does. ``shuffles`` is
    :func:`permuted`'s answer for ``values``.
    """
    keep, shuffled = shuffles
    values, groups = np.asarray(values, dtype=float)[keep], np.asarray(groups)[keep]
    if values.size < 3 or np.var(values) == 0:
        return 1.0
    onehot = np.zeros((values.size, int(groups.max()) + 1))
    onehot[np.arange(values.size), groups] = 1.0
    counts = onehot.sum(axis=0)
    used = counts > 0

    def between(v: np.ndarray) -> np.ndarray:  # between-group sum of squares of each row of v
        sums = v @ onehot[:, used]
        return (sums**2 / counts[used]).sum(axis=-1)

    observed = between(values[None, :])[0]
    return float((1 + np.sum(between(shuffled) >= observed - 1e-12 * abs(observed))) / (1 + PERMUTATIONS))


def _finished(session: Session, study_id: int) -> list[Any]:
    return session.execute(select(Trial.number, Trial.params, Trial.value, Trial.low, Trial.high)
                           .where(Trial.study_id == study_id, Trial.status == SUCCEEDED, Trial.value.is_not(None))
                           .order_by(Trial.number)).all()


def _even(indices: list[int], count: int) -> list[int]:
    if len(indices) <= count:
        return indices
    return [indices[int(i)] for i in np.linspace(0, len(indices) - 1, count).round()]


def _groups(values: list[Any], numeric: bool, distinct: int) -> tuple[list[Any], list[int]]:
    """Labels of the groups and each value's group: the values themselves, or quantile bins."""
    if not numeric or distinct <= BINS:
        labels = sorted(set(values), key=lambda v: (isinstance(v, str), v))
        index = {v: i for i, v in enumerate(labels)}
        return labels, [index[v] for v in values]
    array = np.asarray(values, dtype=float)
    edges = np.unique(np.quantile(array, np.linspace(0, 1, BINS + 1)))
    which = np.clip(np.searchsorted(edges, array, side="right") - 1, 0, len(edges) - 2)
    centres = [float((edges[i] + edges[i + 1]) / 2) for i in range(len(edges) - 1)]
    return centres, which.tolist()


def _mean_ci(values: list[float]) -> tuple[float, float | None, float | None]:
    mean = float(np.mean(values))
    if len(values) < 2:
        return mean, None, None
    half = t_quantile(len(values) - 1) * float(np.std(values, ddof=1)) / math.sqrt(len(values))
    return mean, mean - half, mean + half


def study_plots(session: Session, study_id: int, x: str | None = None, y: str | None = None) -> dict[str, Any]:
    """``GET /api/studies/{id}/plots`` (docs/studies.md); ``x`` and ``y`` choose the heatmap's dimensions."""
    study = get_study(session, study_id)
    plan = plan_of(study)
    names = [d.name for d in plan.dimensions]
    numeric = {d.name: d.kind in ("int", "float") for d in plan.dimensions}
    rows = _finished(session, study_id)
    maximize = plan.objective.direction == "maximize"
    values = [r.value for r in rows]
    out: dict[str, Any] = {"dimensions": names, "direction": plan.objective.direction, "trials": len(rows)}

    best, history, improved = None, [], []
    for i, row in enumerate(rows):
        if best is None or (row.value > best if maximize else row.value < best):
            best = row.value
            improved.append(i)
        history.append((row.number, best))
    keep = sorted(set(_even(list(range(len(history))), MAX_POINTS)) | set(improved[-MAX_POINTS:]))
    out["history"] = {"trial": [history[i][0] for i in keep], "best": [history[i][1] for i in keep],
                      "value": [rows[i].value for i in keep]}

    order = sorted(range(len(rows)), key=lambda i: -values[i] if maximize else values[i])
    shown = sorted(set(order[: MAX_POINTS // 5]) | set(_even(list(range(len(rows))), MAX_POINTS - MAX_POINTS // 5)))
    total = float(np.var(values)) if len(values) > 1 else 0.0
    importance, slices, p_values, levels = {}, {}, {}, {}
    shuffles = permuted(np.asarray(values, dtype=float), seed=study_id)
    for name in names:
        raw = [r.params.get(name) for r in rows]
        labels, groups = _groups(raw, numeric[name], len(set(raw)))
        members: dict[int, list[float]] = defaultdict(list)
        for g, v in zip(groups, values, strict=True):
            members[g].append(v)
        between = sum(len(m) * (np.mean(m) - np.mean(values)) ** 2 for m in members.values()) / max(1, len(values))
        importance[name] = float(between / total) if total > 0 else 0.0
        p_values[name] = eta_squared_p_value(np.asarray(values), np.asarray(groups, dtype=int), shuffles) if rows \
            else 1.0
        levels[name] = len(members)
        means = [_mean_ci(members[g]) if members[g] else (None, None, None) for g in range(len(labels))]
        slices[name] = {
            "x": [raw[i] for i in shown], "value": [values[i] for i in shown],
            "low": [rows[i].low for i in shown], "high": [rows[i].high for i in shown],
            "number": [rows[i].number for i in shown],
            "bins": {"x": labels, "mean": [m[0] for m in means], "low": [m[1] for m in means],
                     "high": [m[2] for m in means], "count": [len(members[g]) for g in range(len(labels))]},
        }
    share = sum(importance.values())
    out["importance"] = {name: {"eta_squared": value, "share": value / share if share > 0 else 0.0,
                                "p_value": p_values[name], "groups": levels[name]}
                         for name, value in importance.items()}
    out["slices"] = slices

    x = x if x in names else names[0]
    y = y if y in names else (names[1] if len(names) > 1 else names[0])
    xs, xg = _groups([r.params.get(x) for r in rows], numeric[x], len({r.params.get(x) for r in rows}))
    ys, yg = _groups([r.params.get(y) for r in rows], numeric[y], len({r.params.get(y) for r in rows}))
    cells: dict[tuple[int, int], list[float]] = defaultdict(list)
    for i, j, v in zip(xg, yg, values, strict=True):
        cells[(i, j)].append(v)
    out["heatmap"] = {"x": x, "y": y, "x_values": xs, "y_values": ys,
                      "mean": [[float(np.mean(cells[(i, j)])) if cells[(i, j)] else None for i in range(len(xs))]
                               for j in range(len(ys))],
                      "count": [[len(cells[(i, j)]) for i in range(len(xs))] for j in range(len(ys))]}
    out["parallel"] = {"number": [rows[i].number for i in shown], "value": [values[i] for i in shown],
                       "params": {name: [rows[i].params.get(name) for i in shown] for name in names}}
    return out
