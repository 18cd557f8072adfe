"""What learning costs a child: the final % from uniform against MG-RAO's groups x, under learning costs.

Run: ``python benchmarks/learning_cost_table.py [--seeds 100] [--costs 0,0.1,0.25,0.5]``. On ``single`` and
``large``, held-out seeds 0 to N-1 (the calibrations used 100-199), the paper's episodes: uniform, every
``mgrao-x:1`` (x dividing the parents; ``mgrao-max`` is x = n_parents), independent-q and the bandit, under each
``learning_cost`` (docs/model.md, "The cost of learning"). Prints each configuration's % from uniform with its
95% interval (paired seed by seed, :meth:`mgrao_core.results.ExperimentResult.summary`), the best x in
hindsight under each cost, and the table docs/model.md shows.
"""

from __future__ import annotations

import argparse

from mgrao_core import make_spec, run_experiment
from mgrao_core.algorithms import divisors, parse_algorithm, task_share
from mgrao_core.presets import get_preset
from mgrao_core.reproduction import PAPER_EPISODES

OTHERS = ("independent-q", "bandit")


def labels(n_parents: int) -> list[str]:
    """uniform, then ``mgrao-x:1`` for every x dividing ``n_parents`` (the last as ``mgrao-max``), then the others."""
    groups = [f"mgrao-{x}:1" for x in divisors(n_parents)[:-1]] + ["mgrao-max"]
    return ["uniform", *groups, *OTHERS]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--costs", default="0,0.1,0.25,0.5")
    parser.add_argument("--systems", default="single,large")
    args = parser.parse_args()
    costs = [float(c) for c in args.costs.split(",")]
    for system in args.systems.split(","):
        n_parents = get_preset(system).params.n_parents
        algorithms = labels(n_parents)
        learners = algorithms[1:]
        print(f"\n{system}: seeds 0-{args.seeds - 1}, {PAPER_EPISODES} episodes; % from uniform [95% interval]")
        print("| configuration | " + " | ".join(f"cost {c:g}" for c in costs) + " |")
        print("|---|" + "---|" * len(costs))
        rows: dict[str, list[str]] = {a: [] for a in learners}
        best: list[str] = []
        for cost in costs:
            spec = make_spec(system, algorithms, seeds=args.seeds, episodes=PAPER_EPISODES,
                             overrides={"learning_cost": cost})
            summary = run_experiment(spec).summary()
            for algorithm in learners:
                s = summary[algorithm]
                share = task_share(parse_algorithm(algorithm, n_parents), spec.params)
                rows[algorithm].append(f"{s.pct_from_uniform:+.1f} [{s.pct_ci95[0]:+.1f}, {s.pct_ci95[1]:+.1f}]"
                                       + (f" ({1 - share:.3g} to learning)" if cost and share < 1 else ""))
            top = max((a for a in learners if a.startswith("mgrao")), key=lambda a: summary[a].pct_from_uniform)
            best.append(f"{top} ({summary[top].pct_from_uniform:+.1f})")
        for algorithm in learners:
            print(f"| {algorithm} | " + " | ".join(rows[algorithm]) + " |")
        print("| best x in hindsight | " + " | ".join(best) + " |")


if __name__ == "__main__":
    main()
