"""Oracle-normalised scores of a comparison's worlds: anchors, scores and the score matrices (docs/statistics.md).

On each world, a run's final utility ``F`` as the share of the oracle's gain over uniform:
``(F - mean uniform) / (mean oracle - mean uniform)`` (:func:`normalisation`). A world whose oracle gain is not
positive, or whose paired 95% interval includes 0, gives no scores (its reason is in the answer).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mgrao_core.statistics._json import pair
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import BASELINE

BEST_FIXED = "oracle"
"""The label whose mean makes a score of 1 (:mod:`mgrao_core.algorithms.oracle`)."""
MIN_SEEDS = 2
"""Fewest seeds per world a score matrix needs (a bootstrap resamples at least two)."""


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
                "gain_ci95": pair(self.gain_ci95), "n_seeds": len(self.seeds), "valid": self.reason is None,
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
