"""Configurations compared across systems: scores, aggregates, profiles, head to head (docs/statistics.md).

The statistics of Agarwal et al. (2021), "Deep reinforcement learning at the edge of the statistical
precipice", over the worlds (systems) of a comparison, each given as its configurations' final utilities by
seed (:class:`~mgrao_core.statistics.scores.World`); nothing here reads a database or runs a simulation.
Each concern has its module: scores (:mod:`~mgrao_core.statistics.scores`), aggregates
(:mod:`~mgrao_core.statistics.metrics`), intervals (:mod:`~mgrao_core.statistics.bootstrap`), P(X > Y)
(:mod:`~mgrao_core.statistics.improvement`), paired tests (:mod:`~mgrao_core.statistics.paired_tests`) and the
limits (:mod:`~mgrao_core.statistics.limits`); this one puts them together into one answer.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from mgrao_core.statistics import metrics
from mgrao_core.statistics._json import number
from mgrao_core.statistics.bootstrap import DEFAULT_REPETITIONS, MAX_REPETITIONS, generator, stratified_bootstrap
from mgrao_core.statistics.improvement import improvement_codes, improvement_of_codes
from mgrao_core.statistics.limits import MAX_RESAMPLED, check_size, check_work
from mgrao_core.statistics.paired_tests import head_to_head
from mgrao_core.statistics.scores import (
    Normalisation,
    ScoreMatrices,
    World,
    finite,
    normalisation,
    representatives,
    score_matrices,
)
from mgrao_core.statistics.student import CONFIDENCE
from mgrao_core.statistics.summary import FINAL_EPISODES, summarise

TAUS = np.linspace(0.0, 1.25, 51)
"""The thresholds of the performance profiles."""
WEIGHTING = ("each system weighs the same in every aggregate, each of its runs 1 / (systems x its runs): the mean "
             "and median of per-system means; the IQM as the weighted 25% trimmed mean; the optimality gap and the "
             "profiles as means over systems; P(X>Y) per system on its own runs (the same as rliable's where every "
             "system has as many runs)")
"""How the aggregates weigh systems that keep different numbers of seeds (docs/statistics.md, "Aggregates")."""


def _interval(result, index: Any = ()) -> dict[str, Any]:
    return {"estimate": number(result.estimate[index]),
            "ci95": [number(result.low[index]), number(result.high[index])]}


def _scored(worlds: Sequence[World], aggregate: Sequence[str]) -> tuple[dict[str, Normalisation], ScoreMatrices]:
    """Each world's anchors, and the score matrices over the worlds that stand for their systems."""
    anchors = {w.name: normalisation(w) for w in worlds}
    chosen, reason = representatives(worlds, aggregate)
    if reason is not None:
        labels = dict.fromkeys(label for w in worlds for label in w.finals)
        return anchors, ScoreMatrices((), {}, {}, {}, {}, {label: "nothing is aggregated" for label in labels},
                                      reason)
    return anchors, score_matrices(worlds, anchors, chosen)


def compare(worlds: Sequence[World], *, repetitions: int = DEFAULT_REPETITIONS, seed: int = 0,
            confidence: float = CONFIDENCE, aggregate: Sequence[str] = ()) -> dict[str, Any]:
    """The comparison's statistics as JSON-ready data (docs/statistics.md, "The answer").

    Args:
        worlds: the worlds compared, in the order shown.
        repetitions: bootstrap repetitions of every interval of the aggregates, profiles and P(X > Y).
        seed: the bootstrap's seed (:func:`mgrao_core.statistics.bootstrap.generator`).
        confidence: the level of every interval.
        aggregate: the worlds that stand for their systems where a system has several
            (:func:`~mgrao_core.statistics.scores.representatives`).

    Raises:
        ConfigError: naming ``jobs`` or ``reps`` (:mod:`~mgrao_core.statistics.limits`), or ``aggregate``.
    """
    worlds, non_finite = finite(worlds)
    check_size(worlds)
    systems = {w.name: {label: s.as_dict() for label, s in summarise(dict(w.finals)).items()} for w in worlds}
    anchors, matrices = _scored(worlds, aggregate)
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
            codes_x, codes_y, width = improvement_codes(matrices.matrices[x], matrices.matrices[y])
            result = stratified_bootstrap(lambda a, b, w=width: improvement_of_codes(a, b, w), codes_x, codes_y,
                                          repetitions=repetitions, rng=generator(seed, x, y), confidence=confidence)
            estimate = float(metrics.probability_of_improvement(matrices.matrices[x], matrices.matrices[y]))
            improvement[f"{x}>{y}"] = {"estimate": estimate, "ci95": [float(result.low), float(result.high)]}
            improvement[f"{y}>{x}"] = {"estimate": 1.0 - estimate, "ci95": [1.0 - float(result.high),
                                                                            1.0 - float(result.low)]}
    pairs = head_to_head(worlds)
    return {
        "systems": systems,
        "normalisation": {w.name: anchors[w.name].as_dict(w.caveats) for w in worlds},
        "scores": {label: {name: matrix[: len(matrices.seeds[label][name]), j].tolist()
                           for j, name in enumerate(matrices.worlds)} for label, matrix in matrices.matrices.items()},
        "aggregate": aggregate,
        "aggregated": _aggregated(worlds, matrices),
        "performance_profiles": {"tau": TAUS.tolist(), "profiles": profiles},
        "probability_of_improvement": improvement,
        "head_to_head": {"pairs": pairs, "tests": sum(p["p_value"] is not None for p in pairs)},
        "protocol": protocol(worlds, repetitions=repetitions, seed=seed, confidence=confidence,
                             tests=sum(p["p_value"] is not None for p in pairs)) | {
            "max_repetitions": min(MAX_REPETITIONS, MAX_RESAMPLED // max(1, per_repetition))},
        "non_finite": non_finite,
    }


def _aggregated(worlds: Sequence[World], matrices: ScoreMatrices) -> dict[str, Any]:
    """What the aggregates stand on: the systems, each one's seeds, what was left out and why."""
    systems = list(matrices.worlds) if matrices.matrices else []
    by_system: dict[str, list[str]] = {}
    for w in worlds:
        by_system.setdefault(w.system, []).append(w.name)
    return {
        "systems": systems,
        "seeds": {name: matrices.anchor_seeds[name] for name in systems},
        "n_seeds": {name: len(matrices.anchor_seeds[name]) for name in systems},
        "runs": {label: {name: len(seeds[name]) for name in systems} for label, seeds in matrices.seeds.items()},
        "left_out": {name: matrices.left_out[name] for name in systems if name in matrices.left_out},
        "worlds_of_system": {system: names for system, names in by_system.items() if len(names) > 1},
        "weighting": WEIGHTING,
        "excluded": matrices.excluded, "reason": matrices.reason,
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
                      "resampling": "seeds with replacement within each system, each configuration independently; "
                                    "the anchors held fixed"},
        "pairing": "seed by seed within a world: % from uniform over the seeds a configuration shares with uniform",
        "score": "(F - mean uniform F) / (mean oracle F - mean uniform F) on each system, the means over the seeds "
                 "with both uniform and oracle runs (the anchor seeds); every score of the system stands on them",
        "weighting": WEIGHTING,
        "test": f"two-sided Wilcoxon signed-rank test on paired differences in % from uniform, Holm-adjusted over "
                f"{tests} test(s)",
    }


def _iqm_of_counts(scores: np.ndarray, counts: list[np.ndarray]) -> np.ndarray:
    if metrics.is_ragged(scores):
        return metrics.aggregate_iqm_of_weighted_counts(scores, counts[0])
    return metrics.aggregate_iqm_of_counts(scores, counts[0])


def sample_efficiency(worlds: Sequence[World], *, repetitions: int = DEFAULT_REPETITIONS, seed: int = 0,
                      confidence: float = CONFIDENCE, aggregate: Sequence[str] = ()) -> dict[str, Any]:
    """IQM of the scores at each bucket of episodes, with bootstrap bands: rliable's sample-efficiency curves.

    On the runs of the final scores' matrices (:func:`~mgrao_core.statistics.scores.score_matrices`), over the
    worlds that stand for their systems (``aggregate``, as :func:`compare`).

    A bucket's score is the run's mean utility over the bucket, normalised with the world's final anchors
    (:func:`~mgrao_core.statistics.scores.normalisation`), so that the last bucket of the final window's width is
    the final score. Every world must give ``curves`` with the same number of buckets.
    """
    worlds, _ = finite(worlds)
    check_size(worlds)
    anchors, matrices = _scored(worlds, aggregate)
    by_name = {w.name: w for w in worlds}
    scored = [by_name[name] for name in matrices.worlds] if matrices.matrices else []
    points = {len(next(iter(next(iter(w.curves.values())).values()))) for w in scored if w.curves}
    if len(points) > 1:
        raise ValueError(f"the worlds' curves have different numbers of buckets: {sorted(points)}")
    count = points.pop() if points else 0
    check_work(repetitions, sum(m.size for m in matrices.matrices.values()) * count)
    curves = {}
    for label, final in matrices.matrices.items():
        # each bucket's scores on the final matrix's runs, (points, runs, worlds), NaN where the final is
        matrix = np.full((count, *final.shape), np.nan)
        for j, w in enumerate(scored):
            for i, s in enumerate(matrices.seeds[label][w.name]):
                matrix[:, i, j] = anchors[w.name].score(np.asarray(w.curves[label][s], dtype=float))
        result = stratified_bootstrap(metrics.aggregate_iqm, matrix, repetitions=repetitions,
                                      rng=generator(seed, "sample-efficiency", label), confidence=confidence,
                                      of_counts=_iqm_of_counts)
        curves[label] = {"iqm": result.estimate.tolist(), "low": result.low.tolist(), "high": result.high.tolist()}
    return {"systems": list(matrices.worlds) if matrices.matrices else [], "seeds": matrices.anchor_seeds,
            "runs": {label: {name: len(s) for name, s in seeds.items()} for label, seeds in matrices.seeds.items()},
            "curves": curves, "excluded": matrices.excluded, "reason": matrices.reason,
            "bootstrap": {"repetitions": repetitions, "seed": seed, "method": "percentile"}}
