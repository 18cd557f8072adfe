"""What resampling the score anchors would change: the aggregates' intervals with fixed and with resampled anchors.

A comparison's scores are ``(F - mean uniform F) / (mean oracle F - mean uniform F)`` per system, the means over
the system's anchor seeds (docs/statistics.md, "Scores"). Its bootstrap resamples the scores and holds the anchors
fixed (rliable's treatment of reference scores). This script measures the alternative on the paper's four systems:
each repetition draws a configuration's seeds within each system and recomputes uniform's and the oracle's means
on the *same* draw (common random numbers: seed s is one world for all three), so the anchors' uncertainty reaches
the interval. It prints, per configuration and aggregate, both intervals and the ratio of their widths.

Run:  python benchmarks/anchor_uncertainty.py [--seeds 100] [--episodes 100] [--reps 10000]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from mgrao_core import PAPER_SYSTEMS, final_utilities, make_spec, run_experiment
from mgrao_core.algorithms.oracle import bound_caveats
from mgrao_core.statistics import metrics
from mgrao_core.statistics.bootstrap import generator
from mgrao_core.statistics.comparison import compare
from mgrao_core.statistics.scores import World

LABELS = ("uniform", "mgrao-1:1", "mgrao-max", "oracle")


def _finals(system: str, seeds: int, episodes: int) -> dict[str, dict[int, float]]:
    result = run_experiment(make_spec(system, list(LABELS), seeds, episodes))
    out: dict[str, dict[int, float]] = {label: {} for label in LABELS}
    for run in result.runs:
        out[run.algorithm][run.seed] = float(final_utilities(run.utilities[None])[0])
    return out


def resampled_anchor_intervals(finals: dict[str, dict[str, dict[int, float]]], label: str, reps: int,
                               seed: int) -> dict[str, tuple[float, float]]:
    """Percentile intervals of the aggregates when each repetition recomputes the anchors on its draw of seeds."""
    systems = list(finals)
    columns = []
    for system in systems:
        seeds = sorted(set(finals[system]["uniform"]) & set(finals[system]["oracle"]) & set(finals[system][label]))
        columns.append(np.array([[finals[system][name][s] for s in seeds] for name in (label, "uniform", "oracle")]))
    rng = generator(seed, "anchors", label)
    values = []
    for start in range(0, reps, 1000):
        size = min(1000, reps - start)
        resampled = []
        for f, u, o in columns:
            idx = rng.integers(0, len(f), size=(size, len(f)))
            uniform, oracle = u[idx].mean(axis=1, keepdims=True), o[idx].mean(axis=1, keepdims=True)
            resampled.append((f[idx] - uniform) / (oracle - uniform))
        values.append(metrics.all_aggregates(np.stack(resampled, axis=-1)))
    low, high = np.percentile(np.concatenate(values), [2.5, 97.5], axis=0)
    return {name: (float(low[k]), float(high[k])) for k, name in enumerate(metrics.AGGREGATES)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--reps", type=int, default=10_000)
    args = parser.parse_args()
    began = time.perf_counter()
    finals = {system: _finals(system, args.seeds, args.episodes) for system in PAPER_SYSTEMS}
    print(f"# {len(PAPER_SYSTEMS)} systems x {len(LABELS)} configurations x {args.seeds} seeds x {args.episodes} "
          f"episodes simulated in {time.perf_counter() - began:.0f} s; {args.reps:,} repetitions")
    worlds = [World(system, system, args.episodes, finals[system],
                    bound_caveats(make_spec(system, ["uniform"], 1, 1).params)) for system in PAPER_SYSTEMS]
    answer = compare(worlds, repetitions=args.reps, seed=0)
    print(f"{'configuration':<12} {'aggregate':<15} {'estimate':>9}  {'fixed anchors':>18}  "
          f"{'resampled anchors':>18}  width ratio")
    for label in LABELS:
        resampled = resampled_anchor_intervals(finals, label, args.reps, seed=0)
        for name in metrics.AGGREGATES:
            fixed = answer["aggregate"][label][name]
            low, high = fixed["ci95"]
            r_low, r_high = resampled[name]
            ratio = (r_high - r_low) / (high - low) if high > low else float("nan")
            print(f"{label:<12} {name:<15} {fixed['estimate']:>9.3f}  [{low:>7.3f}, {high:>7.3f}]  "
                  f"[{r_low:>7.3f}, {r_high:>7.3f}]  {ratio:>10.2f}")


if __name__ == "__main__":
    main()
