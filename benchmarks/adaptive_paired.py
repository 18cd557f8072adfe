"""Do adaptive parent groups beat fixed groups of the same x? Paired seeds, % from uniform.

Run: ``python benchmarks/adaptive_paired.py [--seeds 100-199] [--systems large,single] [--set name=value ...]``.

For every system and x, each seed's final utility (the mean of the last episodes,
:func:`mgrao_core.statistics.summary.final_utilities`) as % from uniform of the same seed, for ``mgrao-x:1``
(fixed, contiguous groups; where x does not divide n_parents, the fixed groups of
``mgrao-adaptive:x`` with ``regroup_every`` beyond the run, the same ``floor(p * x / n)`` groups)
and for ``mgrao-adaptive:x`` under each grouping rule; then the paired difference adaptive - fixed
in percentage points with its 95% t-interval. Every algorithm of a seed faces the same world
(common random numbers), so the pairing removes the seed's own luck. Seeds 100-199 are the
calibration seeds (what the rule was chosen on); 0-99 are held out for the reported figures.
Once the environment has ``unpredictable_fraction`` (issue 21, point 1), add
``--set unpredictable_fraction=0.2``.
"""

from __future__ import annotations

import argparse

import numpy as np

from mgrao_core import make_spec, run_experiment
from mgrao_core.algorithms.adaptive.family import RULES
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import final_utilities

XS = {"single": (2, 5), "multi": (2, 5), "volatile": (2, 5), "large": (2, 5, 10)}


def seeds_of(text: str) -> list[int]:
    """``"100-199"`` or ``"0,3,7"``."""
    if "-" in text:
        low, high = text.split("-")
        return list(range(int(low), int(high) + 1))
    return [int(s) for s in text.split(",")]


def finals(system: str, labels: list[str], seeds: list[int], overrides: dict) -> dict[str, np.ndarray]:
    """Each label's final utility per seed (in seed order)."""
    result = run_experiment(make_spec(system, labels, seeds, 100, overrides))
    return {label: final_utilities(result.utilities(label)) for label in labels}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0-99")
    parser.add_argument("--systems", default="single,multi,volatile,large")
    parser.add_argument("--set", action="append", default=[], help="name=value, a parameter of every run")
    args = parser.parse_args()
    seeds = seeds_of(args.seeds)
    base: dict = {}
    for item in args.set:
        name, _, value = item.partition("=")
        base[name] = value  # make_spec coerces text to the parameter's kind
    print(f"seeds {args.seeds} ({len(seeds)}), overrides {base or 'none'}; pp = percentage points of % from uniform")
    for system in args.systems.split(","):
        for x in XS[system]:
            fixed = f"mgrao-{x}:1"
            runs = finals(system, ["uniform", fixed], seeds, base)
            uniform = runs["uniform"]
            pct_fixed = 100 * (runs[fixed] / uniform - 1)
            line = f"{system:<9} x={x:<3} fixed {pct_fixed.mean():+6.2f}%"
            for rule in RULES:
                adaptive = finals(system, [f"mgrao-adaptive:{x}"], seeds, base | {"regroup_by": rule})
                pct = 100 * (adaptive[f"mgrao-adaptive:{x}"] / uniform - 1)
                mean, low, high = mean_ci95(pct - pct_fixed)
                wins = int((pct > pct_fixed).sum())
                line += f" | {rule}: {pct.mean():+6.2f}%, diff {mean:+5.2f} pp [{low:+5.2f}, {high:+5.2f}] wins {wins}"
            print(line, flush=True)


if __name__ == "__main__":
    main()
