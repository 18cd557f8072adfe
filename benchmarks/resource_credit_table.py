"""``shared`` versus ``by-share`` credit on the ``multi-resource`` preset: the table of docs/model.md.

Run: ``python benchmarks/resource_credit_table.py [--seeds 100]``. Seeds 0 to N-1, 100 episodes, uniform,
mgrao-1:1 and mgrao-max under each ``resource_combination`` and ``resource_credit``; prints each configuration's
final mean utility (last 10 episodes, 95% t-interval) and its % from uniform (paired seed by seed), and, per
combination and learner, the paired difference by-share minus shared in % from uniform with its 95% interval.
"""

from __future__ import annotations

import argparse

import numpy as np

from mgrao_core import make_spec, run_experiment
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import final_utilities

ALGORITHMS = ("uniform", "mgrao-1:1", "mgrao-max")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    args = parser.parse_args()
    print(f"multi-resource (10 parents, 1 child, 2 resources), seeds 0-{args.seeds - 1}, 100 episodes")
    print("| combination | credit | configuration | final utility | % from uniform |")
    print("|---|---|---|---|---|")
    pct: dict[tuple[str, str, str], np.ndarray] = {}
    for combination in ("scarcest", "weighted"):
        for credit in ("shared", "by-share"):
            spec = make_spec("multi-resource", list(ALGORITHMS), seeds=args.seeds, episodes=100,
                             overrides={"resource_combination": combination, "resource_credit": credit})
            result = run_experiment(spec)
            summary = result.summary()
            uniform = final_utilities(result.utilities("uniform"))
            for algorithm in ALGORITHMS:
                s = summary[algorithm]
                pct[(combination, credit, algorithm)] = 100 * (final_utilities(result.utilities(algorithm)) / uniform
                                                               - 1)
                gain = "" if algorithm == "uniform" else (
                    f"{s.pct_from_uniform:+.1f}% [{s.pct_ci95[0]:+.1f}, {s.pct_ci95[1]:+.1f}]")
                half = (s.ci95[1] - s.ci95[0]) / 2
                print(f"| {combination} | {credit} | {algorithm} | {s.final_mean:.3f} ± {half:.3f} | {gain} |")
    print()
    print("| combination | configuration | by-share minus shared (% from uniform, paired) |")
    print("|---|---|---|")
    for combination in ("scarcest", "weighted"):
        for algorithm in ALGORITHMS[1:]:
            d = pct[(combination, "by-share", algorithm)] - pct[(combination, "shared", algorithm)]
            mean, low, high = mean_ci95(d)
            print(f"| {combination} | {algorithm} | {mean:+.2f} [{low:+.2f}, {high:+.2f}] points |")


if __name__ == "__main__":
    main()
