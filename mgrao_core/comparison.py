"""Configurations compared across systems: scores, aggregates, profiles, head to head (docs/statistics.md).

The statistics of Agarwal et al. (2021), "Deep reinforcement learning at the edge of the statistical
precipice", over the worlds (systems) of a comparison, each given as its configurations' final utilities by
seed (:class:`World`); nothing here reads a database or runs a simulation.

* **Score.** On each world, a run's final utility ``F`` as the share of the oracle's gain over uniform:
  ``(F - mean uniform) / (mean oracle - mean uniform)``, both means over the seeds where the world has a
  uniform and an oracle run (:func:`normalisation`). A world whose oracle gain is not positive, or whose paired
  95% interval includes 0, gives no scores (its reason is in the answer).
* **Score matrix.** Per configuration, ``(seeds, worlds)``: the first ``n`` seeds, in seed order, that every
  aggregated configuration shares on each world, the same ``n`` on every world (rliable's matrices are
  rectangular); a configuration missing a world with scores is left out of the aggregates, with its reason.
* **Aggregates** (:mod:`mgrao_core.metrics`): mean, median, IQM and optimality gap, with stratified bootstrap
  intervals (:mod:`mgrao_core.bootstrap`); **performance profiles** (share of runs above tau, tau in [0, 1.25]);
  **probability of improvement** P(X > Y) for both orders of every pair.
* **Head to head**, per world: the paired difference in % from uniform between two configurations over the
  seeds both share with uniform, its 95% t-interval, and the two-sided Wilcoxon signed-rank test, the p-values
  adjusted by Holm's method over every pair of every world.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mgrao_core import metrics
from mgrao_core.bootstrap import DEFAULT_REPETITIONS, MAX_REPETITIONS, generator, stratified_bootstrap
from mgrao_core.errors import ConfigError
from mgrao_core.stats import (
    BASELINE,
    CONFIDENCE,
    FINAL_EPISODES,
    mean_ci95,
    paired_pct_from_uniform,
    summarise,
)

BEST_FIXED = "oracle"
"""The label whose mean makes a score of 1 (:mod:`mgrao_core.algorithms.oracle`)."""
TAUS = np.linspace(0.0, 1.25, 51)
"""The thresholds of the performance profiles."""
MIN_SEEDS = 2
"""Fewest seeds per world a score matrix needs (a bootstrap resamples at least two)."""
MAX_CONFIGURATIONS = 40
"""Configurations of one world at most: the head-to-head tests and P(X > Y) grow with their pairs (780 here)."""
MAX_PAIRED_DIFFERENCES = 5_000_000
"""Paired differences the head-to-head tests of one answer rank at most (pairs x their shared seeds, bounded
from above by each world's pairs x its most seeds): about 5,000 tests of 1,000 seeds, some seconds."""
MAX_RESAMPLED = 500_000_000
"""Resampled scores of one answer's bootstraps at most (repetitions x the scores each repetition draws): about 20 s
on one core; more is refused, naming the repetitions that fit."""


@dataclass(frozen=True)
class World:
    """One world of a comparison and its configurations' runs.

    Attributes:
        name: how the answer names it (unique in the comparison; a system's name where that is unique).
        system: the system (preset) it is based on.
        episodes: episodes per run.
        finals: configuration label -> seed -> the run's final utility (mean of its last episodes), the labels
            in the order they are shown; ``uniform`` and ``oracle`` are the score's anchors.
        caveats: why the oracle's mean is no upper bound here (:func:`mgrao_core.algorithms.oracle.bound_caveats`).
        curves: optional, for :func:`sample_efficiency`: label -> seed -> the run's utilities averaged over
            equal buckets of episodes (the same buckets for every run of the world).
    """

    name: str
    system: str
    episodes: int
    finals: Mapping[str, Mapping[int, float]]
    caveats: Sequence[str] = ()
    curves: Mapping[str, Mapping[int, np.ndarray]] | None = field(default=None, compare=False)


@dataclass(frozen=True)
class Normalisation:
    """A world's score anchors: the mean final utility of uniform and of the oracle over the seeds both ran."""

    seeds: tuple[int, ...]
    uniform: float | None
    oracle: float | None
    gain_ci95: tuple[float, float] | None
    reason: str | None
    """Why the world gives no scores; None when it does."""

    @property
    def gain(self) -> float | None:
        """The oracle's mean gain over uniform (the denominator of a score)."""
        return None if self.uniform is None or self.oracle is None else self.oracle - self.uniform

    def score(self, final: float) -> float:
        """A final utility as the share of the oracle's gain over uniform."""
        return (final - self.uniform) / self.gain

    def as_dict(self, caveats: Sequence[str]) -> dict[str, Any]:
        """JSON-ready, with the world's caveats."""
        return {"uniform": self.uniform, "oracle": self.oracle, "gain": self.gain,
                "gain_ci95": _pair(self.gain_ci95), "n_seeds": len(self.seeds), "valid": self.reason is None,
                "reason": self.reason, "caveats": list(caveats)}


def normalisation(world: World) -> Normalisation:
    """The world's score anchors, or the reason it has none."""
    uniform, oracle = world.finals.get(BASELINE), world.finals.get(BEST_FIXED)
    if uniform is None or oracle is None:
        missing = " and ".join(label for label, runs in ((BASELINE, uniform), (BEST_FIXED, oracle)) if runs is None)
        return Normalisation((), None, None, None, f"no {missing} runs of this world among the compared jobs: "
                                                    f"a score needs both on the same seeds")
    seeds = tuple(sorted(set(uniform) & set(oracle)))
    if len(seeds) < MIN_SEEDS:
        return Normalisation(seeds, None, None, None, f"uniform and oracle share {len(seeds)} seed(s): a score "
                                                      f"needs at least {MIN_SEEDS}")
    u = np.array([uniform[s] for s in seeds])
    o = np.array([oracle[s] for s in seeds])
    _, low, high = mean_ci95(o - u)
    anchors = (seeds, float(u.mean()), float(o.mean()), (low, high))
    gain = anchors[2] - anchors[1]
    if not gain > 0:
        return Normalisation(*anchors, f"the oracle's mean final utility is not above uniform's (gain {gain:.4g})")
    if low <= 0 <= high:
        return Normalisation(*anchors, f"the oracle's gain over uniform, {gain:.4g}, has a 95% interval "
                                       f"[{low:.4g}, {high:.4g}] that includes 0: too few seeds to anchor a score")
    return Normalisation(*anchors, None)


def normalised_scores(world: World, anchors: Normalisation) -> dict[str, dict[int, float]]:
    """Each configuration's score by seed, on the seeds that anchor the world (none without anchors)."""
    if anchors.reason is not None:
        return {}
    anchored = set(anchors.seeds)
    return {label: {s: anchors.score(f) for s, f in sorted(finals.items()) if s in anchored}
            for label, finals in world.finals.items()}


@dataclass(frozen=True)
class ScoreMatrices:
    """The rectangular score matrices of the aggregated configurations."""

    worlds: tuple[str, ...]
    seeds: dict[str, list[int]]
    matrices: dict[str, np.ndarray]
    """Label -> ``(seeds, worlds)``."""
    excluded: dict[str, str]
    reason: str | None = None
    """Why nothing is aggregated (None when something is)."""


def score_matrices(worlds: Sequence[World], anchors: Mapping[str, Normalisation]) -> ScoreMatrices:
    """The configurations that have scores on every world with anchors, on the same count of shared seeds."""
    scored = [w for w in worlds if anchors[w.name].reason is None]
    labels = list(dict.fromkeys(label for w in worlds for label in w.finals))
    if not scored:
        return ScoreMatrices((), {}, {}, {label: "no system of the comparison has scores" for label in labels},
                             "no system has scores: each needs uniform and oracle runs on the same seeds, the "
                             "oracle's gain above 0")
    scores = {w.name: normalised_scores(w, anchors[w.name]) for w in scored}
    names = tuple(w.name for w in scored)
    excluded = {}
    for label in labels:
        missing = [name for name in names if not scores[name].get(label)]
        thin = [name for name in names if 0 < len(scores[name].get(label, ())) < MIN_SEEDS]
        if missing:
            excluded[label] = f"no scored runs on {', '.join(missing)}: aggregates need every scored system"
        elif thin:
            excluded[label] = f"fewer than {MIN_SEEDS} scored seeds on {', '.join(thin)}"
    kept = [label for label in labels if label not in excluded]

    def shared_seeds(among: list[str]) -> dict[str, list[int]]:
        return {name: sorted(set.intersection(*(set(scores[name][label]) for label in among))) for name in names}

    # one configuration on seeds the others lack would leave none shared: the one with the fewest scored seeds
    # goes first, until the rest share enough (uniform and the oracle always have every anchor seed)
    while kept and min(len(s) for s in shared_seeds(kept).values()) < MIN_SEEDS and len(kept) > 1:
        fewest = min(kept, key=lambda label: (sum(len(scores[name][label]) for name in names), -kept.index(label)))
        excluded[fewest] = (f"shares fewer than {MIN_SEEDS} scored seeds with the other configurations on some "
                            "system")
        kept.remove(fewest)
    if not kept:
        return ScoreMatrices(names, {}, {}, excluded, "no configuration has scores on every scored system")
    shared = shared_seeds(kept)
    count = min(len(seeds) for seeds in shared.values())
    if count < MIN_SEEDS:
        return ScoreMatrices(names, {}, {}, excluded, f"the configurations share {count} scored seed(s): aggregates "
                                                      f"need at least {MIN_SEEDS}")
    seeds = {name: shared[name][:count] for name in names}
    matrices = {label: np.array([[scores[name][label][seeds[name][i]] for name in names] for i in range(count)])
                for label in kept}
    return ScoreMatrices(names, seeds, matrices, excluded)


def _pair(values: Sequence[float] | None) -> list[float | None] | None:
    if values is None:
        return None
    return [None if v is None or not math.isfinite(v) else float(v) for v in values]


def _number(value: Any) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def _interval(result, index: Any = ()) -> dict[str, Any]:
    return {"estimate": _number(result.estimate[index]),
            "ci95": [_number(result.low[index]), _number(result.high[index])]}


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
        return {"n_paired": len(d), "difference": _number(d.mean()) if len(d) else None, "ci95": None,
                "p_value": None, "favours": None}
    mean, low, high = mean_ci95(d)
    nonzero = d[d != 0]
    ranks = rankdata(np.abs(nonzero))
    lean = float(ranks[nonzero > 0].sum() - ranks[nonzero < 0].sum())
    p = 1.0 if not len(nonzero) else float(wilcoxon(d).pvalue)
    return {"n_paired": len(d), "difference": _number(mean), "ci95": [_number(low), _number(high)],
            "p_value": _number(p), "favours": "x" if lean > 0 else ("y" if lean < 0 else None)}


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


def _improvement_codes(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """X's and Y's scores as the rank of their value among the distinct values of both, task by task.

    P(X > Y) depends on their order alone, so it is the same of the codes; counting codes is what makes its
    bootstrap fast (:func:`_improvement_of_codes`).
    """
    codes_x, codes_y = np.empty(x.shape, dtype=np.int64), np.empty(y.shape, dtype=np.int64)
    width = 1
    for t in range(x.shape[-1]):
        values, inverse = np.unique(np.concatenate([x[:, t], y[:, t]]), return_inverse=True)
        codes_x[:, t], codes_y[:, t] = inverse[: len(x)], inverse[len(x):]
        width = max(width, len(values))
    return codes_x, codes_y, width


def _improvement_of_codes(codes_x: np.ndarray, codes_y: np.ndarray, width: int) -> np.ndarray:
    """:func:`mgrao_core.metrics.probability_of_improvement` of integer codes in ``[0, width)``, by counting.

    Per batch and task, ``U = sum over codes k of count_x[k] * (count_y below k + count_y[k] / 2)``.
    """
    n_x, n_y = codes_x.shape[-2], codes_y.shape[-2]
    lead, tasks = codes_x.shape[:-2], codes_x.shape[-1]
    rows = int(np.prod(lead, dtype=np.int64)) * tasks
    offset = (np.arange(rows, dtype=np.int64) * width).reshape(*lead, 1, tasks)

    def counts(codes: np.ndarray) -> np.ndarray:
        flat = (codes.astype(np.int64) + offset).ravel()
        return np.bincount(flat, minlength=rows * width).reshape(rows, width).astype(float)

    cx, cy = counts(codes_x), counts(codes_y)
    below = np.cumsum(cy, axis=1) - cy
    u = np.sum(cx * (below + 0.5 * cy), axis=1).reshape(*lead, tasks)
    return np.mean(u / (n_x * n_y), axis=-1)


def finite(worlds: Sequence[World]) -> tuple[list[World], dict[str, dict[str, list[int]]]]:
    """The worlds without runs whose final utility is not finite, and those runs' seeds by world and label."""
    out, dropped = [], {}
    for w in worlds:
        finals = {}
        for label, by_seed in w.finals.items():
            bad = sorted(s for s, f in by_seed.items() if not math.isfinite(f))
            if bad:
                dropped.setdefault(w.name, {})[label] = bad
            finals[label] = {s: f for s, f in by_seed.items() if math.isfinite(f)}
        out.append(dataclasses.replace(w, finals=finals))
    return out, dropped


def check_size(worlds: Sequence[World]) -> None:
    """Refuse (naming ``jobs``) what the statistics cannot bound.

    A world with more than :data:`MAX_CONFIGURATIONS` configurations, or worlds whose paired tests would rank
    more than :data:`MAX_PAIRED_DIFFERENCES` differences.
    """
    for w in worlds:
        if len(w.finals) > MAX_CONFIGURATIONS:
            raise ConfigError("jobs", f"{w.name} has {len(w.finals)} configurations among the jobs: the statistics "
                                      f"compare at most {MAX_CONFIGURATIONS} per system (compare fewer jobs)")
    differences = sum(len(w.finals) * (len(w.finals) - 1) // 2 * max((len(f) for f in w.finals.values()), default=0)
                      for w in worlds)
    if differences > MAX_PAIRED_DIFFERENCES:
        raise ConfigError("jobs", f"the paired tests of these jobs would rank up to {differences:,} differences, over "
                                  f"the limit of {MAX_PAIRED_DIFFERENCES:,} per answer (compare fewer jobs, "
                                  "configurations or seeds)")


def check_work(repetitions: int, per_repetition: int) -> None:
    """Refuse (naming ``reps``) bootstraps that would resample more than :data:`MAX_RESAMPLED` scores."""
    if repetitions * per_repetition > MAX_RESAMPLED:
        fit = max(1, MAX_RESAMPLED // max(1, per_repetition))
        raise ConfigError("reps", f"{repetitions:,} repetitions x {per_repetition:,} scores each exceeds the limit of "
                                  f"{MAX_RESAMPLED:,} resampled scores per answer: use reps <= {fit:,}")


def compare(worlds: Sequence[World], *, repetitions: int = DEFAULT_REPETITIONS, seed: int = 0,
            confidence: float = CONFIDENCE) -> dict[str, Any]:
    """The comparison's statistics as JSON-ready data (docs/statistics.md, "The answer").

    Args:
        worlds: the worlds compared, in the order shown.
        repetitions: bootstrap repetitions of every interval of the aggregates, profiles and P(X > Y).
        seed: the bootstrap's seed (:func:`mgrao_core.bootstrap.generator`).
        confidence: the level of every interval.
    """
    worlds, non_finite = finite(worlds)
    check_size(worlds)
    systems = {w.name: {label: s.as_dict() for label, s in summarise(dict(w.finals)).items()} for w in worlds}
    anchors = {w.name: normalisation(w) for w in worlds}
    matrices = score_matrices(worlds, anchors)
    sizes = [m.size for m in matrices.matrices.values()]
    per_repetition = sum(sizes) + sum(2 * a for i, a in enumerate(sizes) for _ in sizes[i + 1:])
    check_work(repetitions, per_repetition)
    aggregate, profiles, improvement = {}, {}, {}
    for label, matrix in matrices.matrices.items():
        def statistic(scores: np.ndarray) -> np.ndarray:
            return np.concatenate([metrics.all_aggregates(scores), metrics.score_distribution(scores, TAUS)], axis=-1)

        result = stratified_bootstrap(statistic, matrix, repetitions=repetitions, rng=generator(seed, label),
                                      confidence=confidence)
        aggregate[label] = {name: _interval(result, k) for k, name in enumerate(metrics.AGGREGATES)}
        start = len(metrics.AGGREGATES)
        profiles[label] = {"share": result.estimate[start:].tolist(), "low": result.low[start:].tolist(),
                           "high": result.high[start:].tolist()}
    labels = list(matrices.matrices)
    for i, x in enumerate(labels):
        for y in labels[i + 1:]:
            codes_x, codes_y, width = _improvement_codes(matrices.matrices[x], matrices.matrices[y])
            result = stratified_bootstrap(lambda a, b, w=width: _improvement_of_codes(a, b, w), codes_x, codes_y,
                                          repetitions=repetitions, rng=generator(seed, x, y), confidence=confidence)
            estimate = float(metrics.probability_of_improvement(matrices.matrices[x], matrices.matrices[y]))
            improvement[f"{x}>{y}"] = {"estimate": estimate, "ci95": [float(result.low), float(result.high)]}
            improvement[f"{y}>{x}"] = {"estimate": 1.0 - estimate, "ci95": [1.0 - float(result.high),
                                                                            1.0 - float(result.low)]}
    pairs = head_to_head(worlds)
    return {
        "systems": systems,
        "normalisation": {w.name: anchors[w.name].as_dict(w.caveats) for w in worlds},
        "scores": {label: {name: matrix[:, j].tolist() for j, name in enumerate(matrices.worlds)}
                   for label, matrix in matrices.matrices.items()},
        "aggregate": aggregate,
        "aggregated": {"systems": list(matrices.worlds) if matrices.matrices else [], "seeds": matrices.seeds,
                       "n_seeds": len(next(iter(matrices.seeds.values()))) if matrices.seeds else 0,
                       "excluded": matrices.excluded, "reason": matrices.reason},
        "performance_profiles": {"tau": TAUS.tolist(), "profiles": profiles},
        "probability_of_improvement": improvement,
        "head_to_head": {"pairs": pairs, "tests": sum(p["p_value"] is not None for p in pairs)},
        "protocol": protocol(worlds, repetitions=repetitions, seed=seed, confidence=confidence,
                             tests=sum(p["p_value"] is not None for p in pairs)) | {
            "max_repetitions": min(MAX_REPETITIONS, MAX_RESAMPLED // max(1, per_repetition))},
        "non_finite": non_finite,
    }


def protocol(worlds: Sequence[World], *, repetitions: int, seed: int, confidence: float,
             tests: int) -> dict[str, Any]:
    """How every figure of :func:`compare` was made, for a caption or a CSV header."""
    level = f"{100 * confidence:g}%"
    return {
        "final_window": FINAL_EPISODES,
        "final": f"mean system utility of the last {FINAL_EPISODES} episodes of each run",
        "episodes": {w.name: w.episodes for w in worlds},
        "seeds": {w.name: sorted({s for finals in w.finals.values() for s in finals}) for w in worlds},
        "confidence": confidence,
        "interval": f"{level} Student-t interval over seeds (final mean, % from uniform, paired differences); "
                    f"{level} stratified bootstrap percentile interval (aggregates, profiles, P(X>Y))",
        "bootstrap": {"repetitions": repetitions, "seed": seed, "method": "percentile",
                      "resampling": "seeds with replacement within each system, each configuration independently"},
        "pairing": "seed by seed within a world: % from uniform over the seeds a configuration shares with uniform",
        "score": "(F - mean uniform F) / (mean oracle F - mean uniform F) on each system, the means over the seeds "
                 "with both uniform and oracle runs",
        "test": f"two-sided Wilcoxon signed-rank test on paired differences in % from uniform, Holm-adjusted over "
                f"{tests} test(s)",
    }


def _iqm_of_counts(scores: np.ndarray, counts: list[np.ndarray]) -> np.ndarray:
    return metrics.aggregate_iqm_of_counts(scores, counts[0])


def sample_efficiency(worlds: Sequence[World], *, repetitions: int = DEFAULT_REPETITIONS, seed: int = 0,
                      confidence: float = CONFIDENCE) -> dict[str, Any]:
    """IQM of the scores at each bucket of episodes, with bootstrap bands: rliable's sample-efficiency curves.

    On the seeds of the final scores' matrices (:func:`score_matrices`).

    A bucket's score is the run's mean utility over the bucket, normalised with the world's final anchors
    (:func:`normalisation`), so that the last bucket of the final window's width is the final score. Every world
    must give ``curves`` with the same number of buckets.
    """
    worlds, _ = finite(worlds)
    check_size(worlds)
    anchors = {w.name: normalisation(w) for w in worlds}
    matrices = score_matrices(worlds, anchors)
    by_name = {w.name: w for w in worlds}
    scored = [by_name[name] for name in matrices.worlds] if matrices.matrices else []
    points = {len(next(iter(next(iter(w.curves.values())).values()))) for w in scored if w.curves}
    if len(points) > 1:
        raise ValueError(f"the worlds' curves have different numbers of buckets: {sorted(points)}")
    check_work(repetitions, sum(m.size for m in matrices.matrices.values()) * (points.pop() if points else 0))
    curves = {}
    for label in matrices.matrices:
        # each bucket's scores on the aggregated seeds, (seeds, points, worlds)
        stacked = np.stack([np.stack([anchors[w.name].score(np.asarray(w.curves[label][s], dtype=float))
                                      for s in matrices.seeds[w.name]]) for w in scored], axis=-1)
        matrix = np.ascontiguousarray(np.swapaxes(stacked, 0, 1))  # (seeds, points, worlds) -> (points, ...)
        result = stratified_bootstrap(metrics.aggregate_iqm, matrix, repetitions=repetitions,
                                      rng=generator(seed, "sample-efficiency", label), confidence=confidence,
                                      of_counts=_iqm_of_counts)
        curves[label] = {"iqm": result.estimate.tolist(), "low": result.low.tolist(), "high": result.high.tolist()}
    return {"systems": list(matrices.worlds) if matrices.matrices else [], "seeds": matrices.seeds,
            "curves": curves, "excluded": matrices.excluded, "reason": matrices.reason,
            "bootstrap": {"repetitions": repetitions, "seed": seed, "method": "percentile"}}
