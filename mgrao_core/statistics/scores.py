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

from mgrao_core.errors import ConfigError
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
    """The score matrices of the aggregated configurations: each system on its own anchor seeds (ragged).

    Attributes:
        worlds: the aggregated worlds (one per system), the matrices' columns.
        anchor_seeds: world -> the seeds its anchors stand on (every aggregated score stands on them).
        seeds: label -> world -> the seeds of its scores, in seed order (its matrix's rows of that world).
        matrices: label -> ``(runs, worlds)``: on each world its scores in seed order, NaN below their count
            (:mod:`mgrao_core.statistics.metrics`, "Ragged matrices"); rectangular where every world has as many.
        left_out: world -> label -> ``{"seeds", "reason"}``: the runs of the world that are not scored.
        excluded: label -> why the configuration is not aggregated.
        reason: why nothing is aggregated (None when something is).
    """

    worlds: tuple[str, ...]
    anchor_seeds: dict[str, list[int]]
    seeds: dict[str, dict[str, list[int]]]
    matrices: dict[str, np.ndarray]
    left_out: dict[str, dict[str, dict[str, Any]]]
    excluded: dict[str, str]
    reason: str | None = None


def _left_out(world: World, anchors: Normalisation) -> dict[str, dict[str, Any]]:
    """The world's runs on seeds that do not anchor it, by label, with why."""
    uniform, oracle = set(world.finals.get(BASELINE, {})), set(world.finals.get(BEST_FIXED, {}))
    anchored = set(anchors.seeds)
    out = {}
    for label, finals in world.finals.items():
        seeds = sorted(set(finals) - anchored)
        if not seeds:
            continue
        lacking = [name for name, ran in ((BASELINE, uniform), (BEST_FIXED, oracle))
                   if any(s not in ran for s in seeds)]
        why = (f"no {' or '.join(lacking)} run of these seeds among the compared jobs: the anchors stand on the "
               f"seeds with both") if lacking else "not scored"
        out[label] = {"seeds": seeds, "reason": why}
    return out


def score_matrices(worlds: Sequence[World], anchors: Mapping[str, Normalisation],
                   aggregated: Sequence[str] | None = None) -> ScoreMatrices:
    """The configurations that have scores on every aggregated world, each on all its scored seeds.

    Args:
        worlds: the worlds of the comparison.
        anchors: each world's :func:`normalisation`, by name.
        aggregated: the worlds that stand for their systems (:func:`representatives`); by default every world.
    """
    chosen = set(w.name for w in worlds) if aggregated is None else set(aggregated)
    scored = [w for w in worlds if w.name in chosen and anchors[w.name].reason is None]
    labels = list(dict.fromkeys(label for w in worlds if w.name in chosen for label in w.finals))
    if not scored:
        return ScoreMatrices((), {}, {}, {}, {}, {label: "no system of the comparison has scores" for label in labels},
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
    seeds = {label: {name: sorted(scores[name][label]) for name in names} for label in kept}
    matrices = {}
    for label in kept:
        rows = max(len(s) for s in seeds[label].values())
        matrix = np.full((rows, len(names)), np.nan)
        for j, name in enumerate(names):
            matrix[: len(seeds[label][name]), j] = [scores[name][label][s] for s in seeds[label][name]]
        matrices[label] = matrix
    left_out = {w.name: _left_out(w, anchors[w.name]) for w in scored}
    return ScoreMatrices(names, {name: list(anchors[name].seeds) for name in names}, seeds, matrices,
                         {name: out for name, out in left_out.items() if out}, excluded,
                         None if kept else "no configuration has scores on every scored system")


def representatives(worlds: Sequence[World], chosen: Sequence[str] = ()) -> tuple[list[str] | None, str | None]:
    """The worlds that stand for their systems in the aggregates, or why there are none.

    A system's worlds (:attr:`World.system`: the same system at other episodes or parameters) share their seeds'
    draws, so two of them are not two tasks: each system is aggregated once. A system with one world is
    represented by it; one with several, by the world named in ``chosen``, or, if none is named, nothing is
    aggregated (the reason says which worlds to choose between).

    Raises:
        ConfigError: (field ``aggregate``) a name in ``chosen`` that is no world of the comparison, or two
            worlds chosen for one system.
    """
    by_system: dict[str, list[str]] = {}
    for w in worlds:
        by_system.setdefault(w.system, []).append(w.name)
    known = {w.name: w.system for w in worlds}
    unknown = [name for name in chosen if name not in known]
    if unknown:
        raise ConfigError("aggregate", f"{', '.join(map(repr, unknown))}: not a system of this comparison "
                                       f"(systems: {', '.join(map(repr, known))})")
    picked: dict[str, str] = {}
    for name in chosen:
        if picked.get(known[name], name) != name:
            raise ConfigError("aggregate", f"{picked[known[name]]!r} and {name!r} are both worlds of "
                                           f"{known[name]}: choose one to stand for it")
        picked[known[name]] = name
    out, undecided = [], []
    for system, names in by_system.items():
        if len(names) == 1:
            out.append(names[0])
        elif system in picked:
            out.append(picked[system])
        else:
            undecided.append(f"{system} ({'; '.join(names)})")
    if undecided:
        return None, (f"{', '.join(undecided)}: several worlds of one system share their seeds' draws, so they are "
                      "not separate tasks; choose the world that stands for each system (aggregate=) to aggregate")
    return [w.name for w in worlds if w.name in out], None


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
