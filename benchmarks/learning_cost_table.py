"""What learning costs a child: the final % from uniform against MG-RAO's groups x, under learning costs.

Run: ``python benchmarks/learning_cost_table.py [--seeds 100] [--first-seed 0] [--costs 0,0.1,0.25,0.5] [--set
KEY=VALUE ...]``. On ``single`` and ``large``, held-out seeds 0 to N-1 (the calibrations used 100-199:
``--first-seed 100``), the paper's episodes: uniform, every
``mgrao-x:1`` (x dividing the parents; ``mgrao-max`` is x = n_parents), ``mgrao-balance``, independent-q and the
bandit, under each ``learning_cost`` (docs/model.md, "The cost of learning"). Prints each configuration's % from
uniform with its 95% interval (paired seed by seed, :meth:`mgrao_core.results.ExperimentResult.summary`), the best
x in hindsight under each cost, where ``mgrao-balance`` lands against it (the paired difference of their % from
uniform, seed by seed, with its 95% interval) and the groups its children ended with, and the table docs/model.md
shows.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter

from mgrao_core import make_spec, run_experiment
from mgrao_core.algorithms import divisors, parse_algorithm, task_share
from mgrao_core.presets import get_preset
from mgrao_core.reproduction import PAPER_EPISODES
from mgrao_core.results import ExperimentResult
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import final_utilities

BALANCE = "mgrao-balance"
OTHERS = (BALANCE, "independent-q", "bandit")


def labels(n_parents: int) -> list[str]:
    """uniform, then ``mgrao-x:1`` for every x dividing ``n_parents`` (the last as ``mgrao-max``), then the others."""
    groups = [f"mgrao-{x}:1" for x in divisors(n_parents)[:-1]] + ["mgrao-max"]
    return ["uniform", *groups, *OTHERS]


def balance_against(result: ExperimentResult, best: str) -> str:
    """``mgrao-balance``'s % from uniform minus ``best``'s, paired seed by seed, and its children's final groups."""
    uniform = final_utilities(result.utilities("uniform"))
    pct = {a: 100.0 * (final_utilities(result.utilities(a)) / uniform - 1.0) for a in (BALANCE, best)}
    mean, low, high = mean_ci95(pct[BALANCE] - pct[best])
    groups = Counter(int(run.membership[c, -1].max()) + 1 for run in result.runs if run.algorithm == BALANCE
                     for c in range(run.membership.shape[0]))
    shares = ", ".join(f"{m}: {100 * n / sum(groups.values()):.0f}%" for m, n in sorted(groups.items()))
    return f"{mean:+.1f} [{low:+.1f}, {high:+.1f}] (final groups {shares})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--costs", default="0,0.1,0.25,0.5")
    parser.add_argument("--systems", default="single,large")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a parameter for every run (mgrao-balance's balance_tolerance=10, say)")
    args = parser.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    settings = {key: json.loads(value) for key, value in (item.split("=", 1) for item in args.set)}
    costs = [float(c) for c in args.costs.split(",")]
    for system in args.systems.split(","):
        n_parents = get_preset(system).params.n_parents
        algorithms = labels(n_parents)
        learners = algorithms[1:]
        print(f"\n{system}: seeds {seeds[0]}-{seeds[-1]}, {PAPER_EPISODES} episodes; % from uniform [95% interval]"
              + "".join(f", {item}" for item in args.set))
        print("| configuration | " + " | ".join(f"cost {c:g}" for c in costs) + " |")
        print("|---|" + "---|" * len(costs))
        rows: dict[str, list[str]] = {a: [] for a in learners}
        best: list[str] = []
        against: list[str] = []
        for cost in costs:
            spec = make_spec(system, algorithms, seeds=seeds, episodes=PAPER_EPISODES,
                             overrides={**settings, "learning_cost": cost})
            result = run_experiment(spec)
            summary = result.summary()
            for algorithm in learners:
                s = summary[algorithm]
                share = task_share(parse_algorithm(algorithm, n_parents), spec.params)
                fixed_share = cost and share < 1 and algorithm != BALANCE  # balance's changes as it runs
                rows[algorithm].append(f"{s.pct_from_uniform:+.1f} [{s.pct_ci95[0]:+.1f}, {s.pct_ci95[1]:+.1f}]"
                                       + (f" ({1 - share:.3g} to learning)" if fixed_share else ""))
            fixed = [a for a in learners if a.startswith("mgrao") and a != BALANCE]
            top = max(fixed, key=lambda a: summary[a].pct_from_uniform)
            best.append(f"{top} ({summary[top].pct_from_uniform:+.1f})")
            against.append(balance_against(result, top))
        for algorithm in learners:
            print(f"| {algorithm} | " + " | ".join(rows[algorithm]) + " |")
        print("| best x in hindsight | " + " | ".join(best) + " |")
        print(f"| {BALANCE} minus the best x | " + " | ".join(against) + " |")


if __name__ == "__main__":
    main()
