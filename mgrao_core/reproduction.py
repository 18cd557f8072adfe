"""The paper's four tables, ours beside the paper's (pure: returns data, prints nothing)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from mgrao_core.presets import PRESETS
from mgrao_core.results import ExperimentResult
from mgrao_core.runner import run_experiment
from mgrao_core.spec import make_spec

PAPER_EPISODES = 100


def reproduce(
    seeds: int = 30,
    episodes: int = PAPER_EPISODES,
    overrides: Mapping[str, Any] | None = None,
    systems: tuple[str, ...] = tuple(PRESETS),
    on_progress: Callable[[str, float], None] | None = None,
) -> dict[str, ExperimentResult]:
    """Run each system's preset with the paper's algorithms; ``on_progress(system, fraction)``."""
    results = {}
    for name in systems:
        spec = make_spec(name, seeds=seeds, episodes=episodes, overrides=overrides)
        callback = None if on_progress is None else (lambda f, name=name: on_progress(name, f))
        results[name] = run_experiment(spec, on_progress=callback)
    return results


def reproduction_table(results: Mapping[str, ExperimentResult]) -> dict[str, Any]:
    """``{"systems": {system: {algorithm: row}}}`` with ours and the paper's figures per row.

    Each row holds ``pct_from_uniform`` with its ``ci95``, ``pct_of_max``, ``final_mean`` with
    ``final_ci95``, and ``paper_pct_from_uniform`` / ``paper_pct_of_max`` (None where the paper
    has no figure, e.g. for uniform itself).
    """
    systems: dict[str, Any] = {}
    for name, result in results.items():
        paper = PRESETS[name].paper_pct_from_uniform
        rows = {}
        for label, summary in result.summary().items():
            rows[label] = {
                "pct_from_uniform": summary.pct_from_uniform,
                "ci95": list(summary.pct_ci95) if summary.pct_ci95 else None,
                "pct_of_max": summary.pct_of_max,
                "final_mean": summary.final_mean,
                "final_ci95": list(summary.ci95),
                "paper_pct_from_uniform": paper.get(label),
                "paper_pct_of_max": PRESETS[name].paper_pct_of_max.get(label),
            }
        systems[name] = rows
    return {"systems": systems}
