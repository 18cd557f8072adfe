"""What sharing buys: ``mgrao-x:y`` (teams of y children sharing one model) against ``mgrao-x:1``.

    python benchmarks/shared_models_table.py [--seeds 30] [--first-seed 0] [--episodes 100] [--costs 0,0.25]
                                             [--systems multi,cloud,edge] [--set KEY=VALUE ...]

On ``multi`` (3 children), ``cloud`` (8 servers, two resources, tasks that fail and borrow) and ``edge`` (500
servers on a ring, 5,000 users), held-out seeds 0 to N-1, every configuration of one system and one cost in one
experiment (common random numbers: each seed's world and draws are uniform's, docs/statistics.md). For each x and
y of the system (``SETTINGS``) and each ``learning_cost`` (docs/model.md, "The cost of learning"), prints:

* % from uniform, the mean over seeds of each seed's final utility against uniform's of the same seed, with its 95%
  t-interval (:func:`mgrao_core.statistics.student.mean_ci95`);
* for y > 1, the paired difference from ``mgrao-x:1`` (points of % from uniform, seed by seed), with its 95%
  t-interval;
* the memory per child (bytes, the registry's ``memory_per_child``: a team's state over y);

and, per system and cost, the best shared configuration (y > 1) against the best unshared one (y = 1), each the
highest mean % from uniform of its kind (chosen in hindsight), their paired difference with its 95% t-interval.

``--why`` prints instead what the loss without a cost stands on, on ``multi`` (``mgrao-5:1`` against
``mgrao-5:3``, every child in one team): how far apart the children's own final allocations are under
``mgrao-5:1`` (mean total variation distance over pairs of children and seeds), and ``mgrao-5:3`` with its learning
rate divided by 3 (a team takes three children's values: is the loss the faster learning?).

The tables of docs/algorithms.md ("What sharing buys") come from the defaults.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from mgrao_core import make_spec, run_experiment
from mgrao_core.algorithms import describe_label
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import final_utilities

SETTINGS = {  # system: (the x, the y); y = 1 is each x's unshared mgrao-x:1
    "multi": ((1, 5, 10), (1, 3)),
    "cloud": ((1, 5, 40), (1, 2, 4, 8)),
    "edge": ((1, 10, 100), (1, 5, 25, 100)),
}


def interval(values: np.ndarray) -> str:
    """``mean [low, high]`` of ``values`` (95% t-interval), one decimal."""
    mean, low, high = mean_ci95(values)
    return f"{mean:+.1f} [{low:+.1f}, {high:+.1f}]"


def table(system: str, seeds: list[int], episodes: int, cost: float, settings: dict) -> tuple[list[str], str]:
    """The rows of one system under one cost (markdown), after running every configuration together, and the row
    of the best shared configuration against the best unshared one."""
    groups, sizes = SETTINGS[system]
    labels = [f"mgrao-{x}:{y}" for x in groups for y in sizes]
    spec = make_spec(system, ["uniform", *labels], seeds=seeds, episodes=episodes,
                     overrides={**settings, "learning_cost": cost})
    start = time.perf_counter()
    result = run_experiment(spec)
    seconds = time.perf_counter() - start
    uniform = final_utilities(result.utilities("uniform"))
    pct = {label: 100.0 * (final_utilities(result.utilities(label)) / uniform - 1.0) for label in labels}
    rows = []
    for x in groups:
        for y in sizes:
            label = f"mgrao-{x}:{y}"
            memory = describe_label(label, spec.params)["memory_per_child"]
            against = "" if y == 1 else interval(pct[label] - pct[f"mgrao-{x}:1"])
            rows.append(f"| {system} | {cost:g} | {x} | {y} | {interval(pct[label])} | {against} | {memory:,} |")
    print(f"  ({system}, cost {cost:g}: {len(labels) + 1} configurations x {len(seeds)} seeds in {seconds:.0f} s)",
          flush=True)
    best_own = max((label for label in labels if label.endswith(":1")), key=lambda label: pct[label].mean())
    best_shared = max((label for label in labels if not label.endswith(":1")), key=lambda label: pct[label].mean())
    best = (f"| {system} | {cost:g} | {best_own} {interval(pct[best_own])} | {best_shared} "
            f"{interval(pct[best_shared])} | {interval(pct[best_shared] - pct[best_own])} |")
    return rows, best


def why(seeds: list[int], episodes: int) -> None:
    """What the loss of sharing without a cost stands on, on ``multi`` (the module's ``--why``)."""
    own, shared = "mgrao-5:1", "mgrao-5:3"
    result = run_experiment(make_spec("multi", ["uniform", own, shared], seeds=seeds, episodes=episodes))
    uniform = final_utilities(result.utilities("uniform"))
    pct = {label: 100.0 * (final_utilities(result.utilities(label)) / uniform - 1.0) for label in (own, shared)}
    for label in (own, shared):
        apart = [0.5 * np.abs(run.combined_weights[i] - run.combined_weights[j]).sum()
                 for run in result.runs if run.algorithm == label
                 for i in range(run.combined_weights.shape[0]) for j in range(i)]
        print(f"{label}: % from uniform {interval(pct[label])}; the children's final allocations "
              f"{np.mean(apart):.3f} apart (mean total variation distance)")
    slow = run_experiment(make_spec("multi", ["uniform", shared], seeds=seeds, episodes=episodes,
                                    overrides={"learning_rate": 0.1 / 3}))
    slow_pct = 100.0 * (final_utilities(slow.utilities(shared)) / final_utilities(slow.utilities("uniform")) - 1.0)
    print(f"{shared} at learning_rate 0.1 / 3: % from uniform {interval(slow_pct)}, minus {own} at 0.1: "
          f"{interval(slow_pct - pct[own])}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--costs", default="0,0.25")
    parser.add_argument("--systems", default="multi,cloud,edge")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a parameter for every run")
    parser.add_argument("--why", action="store_true", help="what the loss without a cost stands on, on multi")
    args = parser.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    if args.why:
        why(seeds, args.episodes)
        return
    settings = {key: json.loads(value) for key, value in (item.split("=", 1) for item in args.set)}
    print(f"seeds {seeds[0]}-{seeds[-1]}, {args.episodes} episodes" + "".join(f", {s}" for s in args.set))
    tables = [table(system, seeds, args.episodes, cost, settings) for system in args.systems.split(",")
              for cost in map(float, args.costs.split(","))]
    print("\n| system | learning_cost | x | y | % from uniform [95% CI] | minus mgrao-x:1, points [95% CI] "
          "| memory per child (B) |")
    print("| --- | ---: | ---: | ---: | --- | --- | ---: |")
    print("\n".join(row for rows, _ in tables for row in rows))
    print("\n| system | learning_cost | best mgrao-x:1 | best mgrao-x:y (y > 1) "
          "| shared minus unshared, points [95% CI] |")
    print("| --- | ---: | --- | --- | --- |")
    print("\n".join(best for _, best in tables))


if __name__ == "__main__":
    main()
