"""The paper's four tables, ours beside the paper's (pure: returns data, prints nothing)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from mgrao_core.presets import PAPER_SYSTEMS, PRESETS
from mgrao_core.results import ExperimentResult
from mgrao_core.spec import make_spec
from mgrao_core.statistics.summary import ConfigSummary

PAPER_EPISODES = 100
DEFAULT_SEEDS = 100
NON_VOLATILE = ("single", "multi", "large")
"""The systems whose ten figures the environment is calibrated on (see docs/reproduction.md)."""

READINGS: dict[str, dict[str, Any]] = {
    "default": {},
    "relative-linear": {"quality_model": "relative-linear", "routing": "per-task"},
    "exponential": {"quality_model": "exponential"},
    "load-sharing": {"load_sharing": True},
    "per-task": {"routing": "per-task"},
    "counted": {"absent_tasks": "counted"},
}
"""Named environment readings (``mgrao reproduce --reading NAME``): overrides of the defaults.
``relative-linear`` is the project's first reading (relative-linear quality, per-task routing)."""


@dataclass(frozen=True)
class PaperFigure:
    """One figure of the paper's tables beside ours.

    Attributes:
        system: the preset.
        algorithm: the configuration.
        ours: our % from uniform.
        ci95: its 95% interval over seeds.
        paper: the paper's % from uniform.
        deviation: ours minus the paper's, in percentage points.
        outside: whether the paper's figure lies outside our interval.
    """

    system: str
    algorithm: str
    ours: float
    ci95: tuple[float, float]
    paper: float
    deviation: float
    outside: bool


def reproduce(
    seeds: int | Sequence[int] = DEFAULT_SEEDS,
    episodes: int = PAPER_EPISODES,
    overrides: Mapping[str, Any] | None = None,
    systems: Sequence[str] = PAPER_SYSTEMS,
    on_progress: Callable[[str, float], None] | None = None,
    on_compile: Callable[[Any], None] | None = None,
) -> dict[str, ExperimentResult]:
    """Run each system's preset with the paper's algorithms; ``on_progress(system, fraction)``.

    Args:
        seeds: a count (seeds ``0 .. S-1``) or an explicit list, e.g. calibration seeds.
        episodes: episodes per run.
        overrides: parameters changed in every system (e.g. a reading from :data:`READINGS`).
        systems: which presets (the paper's four by default).
        on_progress: called with the system's name and its fraction done.
        on_compile: told when the engine is compiled (:func:`mgrao_core.runner.run_experiment`).
    """
    from mgrao_core import runner  # the compiled engine, loaded when a reproduction runs

    results = {}
    for name in systems:
        spec = make_spec(name, seeds=seeds, episodes=episodes, overrides=overrides)
        callback = None if on_progress is None else (lambda f, name=name: on_progress(name, f))
        results[name] = runner.run_experiment(spec, on_progress=callback, on_compile=on_compile)
    return results


def figures_of(system: str, summary: Mapping[str, ConfigSummary]) -> list[PaperFigure]:
    """The paper's figures of ``system`` beside ours, from the summaries of its configurations."""
    figures = []
    for label, paper in PRESETS[system].paper_pct_from_uniform.items():
        row = summary.get(label)
        if row is None or row.pct_from_uniform is None:
            continue
        low, high = row.pct_ci95 if row.pct_ci95 else (float("nan"), float("nan"))
        figures.append(PaperFigure(
            system=system, algorithm=label, ours=row.pct_from_uniform, ci95=(low, high), paper=paper,
            deviation=row.pct_from_uniform - paper, outside=not low <= paper <= high,
        ))
    return figures


def paper_figures(results: Mapping[str, ExperimentResult]) -> list[PaperFigure]:
    """Every figure of the paper's tables for the systems in ``results``, ours beside it."""
    return [figure for name, result in results.items() for figure in figures_of(name, result.summary())]


def worst_deviation(results: Mapping[str, ExperimentResult]) -> float:
    """The largest absolute difference from the paper over the figures of ``results``."""
    return max(abs(f.deviation) for f in paper_figures(results))


def overtaking_episode(result: ExperimentResult, leader: str = "mgrao-max", follower: str = "mgrao-1:1") -> int | None:
    """The first episode (1-based) from which ``leader`` stays ahead of ``follower`` to the end.

    Compares the mean utility over seeds per episode; None if ``leader`` is not ahead at the last
    episode.
    """
    if leader not in result.spec.algorithms or follower not in result.spec.algorithms:
        return None
    ahead = result.utilities(leader).mean(axis=0) > result.utilities(follower).mean(axis=0)
    if not ahead[-1]:
        return None
    behind = np.flatnonzero(~ahead)
    return int(behind[-1]) + 2 if behind.size else 1


def reproduction_table(results: Mapping[str, ExperimentResult]) -> dict[str, Any]:
    """``{"systems": {system: {algorithm: row}}, "max_overtakes_1_1_at": {system: episode}}``.

    Each row holds ``pct_from_uniform`` with its ``ci95``, ``pct_of_max`` (the paper's
    definition: the gain over uniform as a share of mgrao-max's), ``final_mean`` with
    ``final_ci95``, ``paper_pct_from_uniform`` / ``paper_pct_of_max`` (None where the paper has no
    figure, e.g. for uniform itself) and ``paper_outside_ci`` (None without a paper figure).
    ``max_overtakes_1_1_at`` is :func:`overtaking_episode` per system.
    """
    systems: dict[str, Any] = {}
    overtakes: dict[str, int | None] = {}
    for name, result in results.items():
        paper = PRESETS[name].paper_pct_from_uniform
        rows = {}
        for label, summary in result.summary().items():
            ci = list(summary.pct_ci95) if summary.pct_ci95 else None
            figure = paper.get(label)
            outside = None
            if figure is not None and ci is not None:
                outside = not ci[0] <= figure <= ci[1]
            rows[label] = {
                "pct_from_uniform": summary.pct_from_uniform,
                "ci95": ci,
                "pct_of_max": summary.pct_of_max,
                "final_mean": summary.final_mean,
                "final_ci95": list(summary.ci95),
                "paper_pct_from_uniform": figure,
                "paper_pct_of_max": PRESETS[name].paper_pct_of_max.get(label),
                "paper_outside_ci": outside,
            }
        systems[name] = rows
        overtakes[name] = overtaking_episode(result)
    return {"systems": systems, "max_overtakes_1_1_at": overtakes}
