"""Head to head within a world: paired differences in % from uniform, Wilcoxon's test, Holm's adjustment.

Per world, every pair of configurations: the paired difference in % from uniform over the seeds both share
with uniform, its 95% t-interval, and the two-sided Wilcoxon signed-rank test, the p-values adjusted by Holm's
method over every pair of every world.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from mgrao_core.statistics._json import number
from mgrao_core.statistics.scores import World
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import BASELINE, paired_pct_from_uniform


def holm(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjustment of ``p_values``, which bounds the family-wise error rate.

    The k-th smallest of m p-values is multiplied by ``m - k + 1``, made non-decreasing in that order, capped at 1.
    """
    order = np.argsort(p_values, kind="stable")
    count = len(p_values)
    adjusted = np.empty(count)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (count - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted.tolist()


def paired_difference(x: Mapping[int, float], y: Mapping[int, float]) -> dict[str, Any]:
    """X minus Y over the seeds both have: the mean, its 95% t-interval and the Wilcoxon signed-rank p-value.

    ``x`` and ``y`` are seed -> % from uniform. The test is two-sided on the differences' distribution about 0
    (scipy's ``wilcoxon``: exact below 50 pairs without ties or zeros, else the normal approximation; zero
    differences dropped); every difference 0 gives p = 1. Fewer than two pairs: no interval, no test.
    ``favours`` is the side the test leans to: ``"x"`` where the positive differences' ranks outweigh the
    negative ones' (``W+ > W-``), ``"y"`` the other way, None when they balance.
    """
    from scipy.stats import rankdata, wilcoxon

    seeds = sorted(set(x) & set(y))
    d = np.array([x[s] - y[s] for s in seeds])
    if len(d) < 2:
        return {"n_paired": len(d), "difference": number(d.mean()) if len(d) else None, "ci95": None,
                "p_value": None, "favours": None}
    mean, low, high = mean_ci95(d)
    nonzero = d[d != 0]
    ranks = rankdata(np.abs(nonzero))
    lean = float(ranks[nonzero > 0].sum() - ranks[nonzero < 0].sum())
    p = 1.0 if not len(nonzero) else float(wilcoxon(d).pvalue)
    return {"n_paired": len(d), "difference": number(mean), "ci95": [number(low), number(high)],
            "p_value": number(p), "favours": "x" if lean > 0 else ("y" if lean < 0 else None)}


def head_to_head(worlds: Sequence[World]) -> list[dict[str, Any]]:
    """Every pair of configurations of each world: the paired difference in % from uniform, Holm-adjusted."""
    pairs = []
    for w in worlds:
        baseline = w.finals.get(BASELINE)
        pct = {label: paired_pct_from_uniform(finals, baseline) for label, finals in w.finals.items()}
        labels = [label for label in w.finals if pct[label]]
        for i, x in enumerate(labels):
            for y in labels[i + 1:]:
                pairs.append({"system": w.name, "x": x, "y": y} | paired_difference(pct[x], pct[y]))
    tested = [p for p in pairs if p["p_value"] is not None]
    for p, q in zip(tested, holm([p["p_value"] for p in tested]), strict=True):
        p["p_holm"] = q
    for p in pairs:
        p.setdefault("p_holm", None)
    return pairs
