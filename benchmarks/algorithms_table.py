"""docs/algorithms.md's results table: every algorithm against uniform on the paper's four systems.

Run: ``python benchmarks/algorithms_table.py`` (100 held-out seeds 0 .. 99, 100 episodes; about three
minutes on 2 cores). ``--seeds``, ``--first-seed``, ``--systems``, ``--set NAME=VALUE`` (every
system) and ``--json FILE`` as for ``mgrao reproduce``.

Per system and algorithm: % from uniform with its 95% interval, each seed paired with uniform's run
of the same seed (common random numbers), exactly as ``mgrao reproduce`` and ``mgrao run`` compute
it (:func:`mgrao_core.statistics.summary.summarise`); the share of the oracle's headroom reached (its % from
uniform as a share of the oracle's); and one child's memory in bytes (the registry's
``memory_per_child``). Then the paired differences that answer "does MG-RAO beat the standard
learners": per seed, a learner's % from uniform minus MG-RAO's, mean and 95% interval (negative:
MG-RAO is ahead).
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from mgrao_core import PRESETS, make_spec, run_experiment
from mgrao_core.algorithms import describe_label
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import final_utilities, paired_pct_from_uniform

SYSTEMS = ("single", "multi", "volatile", "large")
LEARNERS = ("independent-q", "bandit")


def algorithms_of(system: str) -> list[str]:
    """The paper's configurations of ``system`` (uniform, its MG-RAO), the standard learners, the oracle."""
    return [*PRESETS[system].algorithms, *LEARNERS, "oracle"]


def per_seed_pct(result) -> dict[str, np.ndarray]:
    """Each algorithm's % from uniform per seed, in the spec's seed order."""
    seeds = result.spec.seeds
    finals = {a: dict(zip(seeds, final_utilities(result.utilities(a)).tolist(), strict=True))
              for a in result.spec.algorithms}
    return {a: np.array(list(paired_pct_from_uniform(finals[a], finals["uniform"]).values()))
            for a in result.spec.algorithms}


def table(system: str, result) -> tuple[list[dict], list[dict]]:
    """The rows of ``system``: one per algorithm, and the paired differences learner minus MG-RAO."""
    summary = result.summary()
    pct = per_seed_pct(result)
    oracle = summary["oracle"].pct_from_uniform
    params = result.spec.params
    rows = []
    for label, s in summary.items():
        if label == "uniform":
            continue
        low, high = s.pct_ci95
        rows.append({"system": system, "algorithm": label, "pct": s.pct_from_uniform, "ci95": [low, high],
                     "headroom": 100.0 * s.pct_from_uniform / oracle if oracle else None,
                     "memory": describe_label(label, params)["memory_per_child"]})
    differences = []
    for learner in LEARNERS:
        for mgrao in ("mgrao-1:1", "mgrao-max"):
            mean, low, high = mean_ci95(pct[learner] - pct[mgrao])
            differences.append({"system": system, "learner": learner, "versus": mgrao, "mean": mean,
                                "ci95": [low, high]})
    return rows, differences


def main() -> None:
    """Run the systems and print both tables as Markdown."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--systems", default=",".join(SYSTEMS))
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--json", help="write every number to this file")
    args = parser.parse_args()
    overrides = dict(s.split("=", 1) for s in args.sets)
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    started = time.perf_counter()
    rows, differences = [], []
    for system in args.systems.split(","):
        spec = make_spec(system, algorithms_of(system), seeds=seeds, episodes=args.episodes, overrides=overrides)
        more_rows, more_differences = table(system, run_experiment(spec))
        rows += more_rows
        differences += more_differences
    print(f"% from uniform after {args.episodes} episodes (mean of the last 10), seeds {seeds[0]}..{seeds[-1]}"
          + (f", {', '.join(f'{k}={v}' for k, v in overrides.items())}" if overrides else "") + "\n")
    print("| system | algorithm | % from uniform | 95% CI | % of the oracle's gain | memory per child (bytes) |")
    print("| --- | --- | ---: | --- | ---: | ---: |")
    for r in rows:
        headroom = "" if r["headroom"] is None else f"{r['headroom']:.0f}"
        print(f"| {r['system']} | {r['algorithm']} | {r['pct']:+.1f} | [{r['ci95'][0]:+.1f}, {r['ci95'][1]:+.1f}] "
              f"| {headroom} | {r['memory']:,} |")
    print("\nPaired by seed: the learner's % from uniform minus MG-RAO's (negative: MG-RAO ahead)\n")
    print("| system | learner | minus | mean (points) | 95% CI |")
    print("| --- | --- | --- | ---: | --- |")
    for d in differences:
        print(f"| {d['system']} | {d['learner']} | {d['versus']} | {d['mean']:+.1f} "
              f"| [{d['ci95'][0]:+.1f}, {d['ci95'][1]:+.1f}] |")
    print(f"\nsimulation {time.perf_counter() - started:.0f} s")
    if args.json:
        with open(args.json, "w") as out:
            json.dump({"seeds": [seeds[0], seeds[-1]], "overrides": overrides, "rows": rows,
                       "differences": differences}, out, indent=2)


if __name__ == "__main__":
    main()
