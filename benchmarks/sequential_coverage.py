"""Seeds until decided: the stopping rules' coverage and error rates, measured on the real engine.

    python benchmarks/sequential_coverage.py [--jobs-single 200] [--jobs-large 500] [--half-width 2]
        [--truth-seeds 5000] [--decide-jobs 200]

* **half_width rule**, per system (single, large) with its paper configurations and 100 episodes:
  ``--jobs-*`` independent sequential jobs (``mgrao_core.statistics.sequential.run_until``, blocks of 10, at most 500
  seeds), job ``k`` on its own seed range ``1,000,000 + 500 k ...`` (disjoint). Each stopped interval of each
  configuration is checked against its mean % from uniform over ``--truth-seeds`` further seeds (from
  100,000,000). Printed: the coverage per configuration with its Wilson 95% interval (target: point at least
  94% and upper end at least 95%), and the seeds used (mean, median, largest; a fixed design would take
  100).
* **decide rule** on single, ``--decide-jobs`` jobs each (seed ranges from 50,000,000): a pair with a known
  difference (mgrao-max against mgrao-1:1; margin of no practical difference 2 points) and a pair with
  almost none (large's mgrao-10:1 against mgrao-25:1, whose 5,000-seed difference is printed), with how often
  each outcome came, how often the stopped interval held the 5,000-seed difference, and the seeds.
* **decide rule with no difference at all**: ``--null-jobs`` sequences drawn with replacement from the first
  pair's 5,000 per-seed differences, centred (a real, skewed distribution whose mean is exactly 0), judged
  block by block as a job judges them, without a margin (every decision is false) and with a margin of 2.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from mgrao_core import final_utilities, make_spec, run_experiment  # noqa: E402
from mgrao_core.statistics.sequential import judge, judged_values, make_until, run_until  # noqa: E402

TRUTH_FIRST, JOBS_FIRST, DECIDE_FIRST = 100_000_000, 1_000_000, 50_000_000
SYSTEMS = {"single": ("uniform", "mgrao-1:1", "mgrao-max"),
           "large": ("uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max")}
DECIDE = {"known difference": ("single", ("uniform", "mgrao-1:1", "mgrao-max"), ("mgrao-max", "mgrao-1:1")),
          "almost none": ("large", ("uniform", "mgrao-10:1", "mgrao-25:1"), ("mgrao-10:1", "mgrao-25:1"))}
EPISODES = 100


def wilson(hits: int, n: int, z: float = 1.959964) -> tuple[float, float]:
    """The Wilson score 95% interval of a proportion."""
    p = hits / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def truth(system: str, algorithms: tuple[str, ...], seeds: int, of_pair: tuple[str, str] | None = None,
          differences: list | None = None) -> dict:
    """Each configuration's mean % from uniform (and a pair's mean difference) over ``seeds`` seeds.

    With ``differences``, the pair's per-seed differences are appended to it.
    """
    until = make_until({"half_width": 1.0}, algorithms)
    values: dict[str, dict[int, float]] = {}
    for start in range(0, seeds, 1000):
        chunk = list(range(TRUTH_FIRST + start, TRUTH_FIRST + min(seeds, start + 1000)))
        spec = make_spec(system, list(algorithms), chunk, EPISODES)
        result = run_experiment(spec)
        finals = {a: dict(zip(spec.seeds, final_utilities(result.utilities(a)).tolist(), strict=True))
                  for a in algorithms}
        for label, by_seed in judged_values(until, finals).items():
            values.setdefault(label, {}).update(by_seed)
    means = {label: statistics.fmean(v.values()) for label, v in values.items()}
    if of_pair:
        a, b = of_pair
        paired = [values[a][s] - values[b][s] for s in values[a] if s in values[b]]
        means[f"{a} - {b}"] = statistics.fmean(paired)
        if differences is not None:
            differences.extend(paired)
    return means


def job(system: str, algorithms: tuple[str, ...], rule: dict, first: int):
    until = make_until(rule, algorithms)
    spec = make_spec(system, list(algorithms), list(range(first, first + until.max_seeds)), EPISODES)
    return run_until(spec, until, run_experiment)


def coverage(system: str, jobs: int, half_width: float, truth_seeds: int) -> None:
    algorithms = SYSTEMS[system]
    started = time.perf_counter()
    true = truth(system, algorithms, truth_seeds)
    hits = {label: 0 for label in true}
    used, reasons = [], {}
    for k in range(jobs):
        done = job(system, algorithms, {"half_width": half_width}, JOBS_FIRST + 500 * k)
        used.append(done.stopped.seeds)
        reasons[done.stopped.reason] = reasons.get(done.stopped.reason, 0) + 1
        for label, (_, low, high) in done.stopped.intervals.items():
            hits[label] += low <= true[label] <= high
    print(f"{system}: {jobs} jobs, half_width {half_width}, truth over {truth_seeds} seeds "
          f"({time.perf_counter() - started:.0f} s); stopped: {reasons}")
    print(f"  seeds used: mean {statistics.fmean(used):.1f}, median {statistics.median(used):.0f}, "
          f"largest {max(used)} (a fixed design: 100)")
    for label, hit in hits.items():
        low, high = wilson(hit, jobs)
        print(f"  {label:12s} truth {true[label]:7.3f}  coverage {hit / jobs:.3f} [{low:.3f}, {high:.3f}]")


def _report(outcomes: dict[str, int], jobs: int, used: list[int]) -> None:
    for outcome, count in sorted(outcomes.items()):
        low, high = wilson(count, jobs)
        print(f"  {outcome:12s} {count / jobs:.3f} [{low:.3f}, {high:.3f}]")
    print(f"  seeds used: mean {statistics.fmean(used):.1f}, median {statistics.median(used):.0f}, "
          f"largest {max(used)}")


def decide(name: str, jobs: int, truth_seeds: int, differences: list | None = None) -> None:
    system, algorithms, pair = DECIDE[name]
    started = time.perf_counter()
    true = truth(system, algorithms, truth_seeds, pair, differences)
    key = f"{pair[0]} - {pair[1]}"
    outcomes, used, covered = {}, [], 0
    for k in range(jobs):
        done = job(system, algorithms, {"decide": list(pair), "half_width": 2.0}, DECIDE_FIRST + 500 * k)
        outcome = done.stopped.outcome or done.stopped.reason
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
        used.append(done.stopped.seeds)
        _, low, high = done.stopped.intervals[key]
        covered += low <= true[key] <= high
    print(f"decide, {name}: {system} {key}, 5,000-seed difference {true[key]:.3f} points; {jobs} jobs "
          f"({time.perf_counter() - started:.0f} s)")
    low, high = wilson(covered, jobs)
    print(f"  the stopped interval holds the 5,000-seed difference: {covered / jobs:.3f} [{low:.3f}, {high:.3f}]")
    _report(outcomes, jobs, used)


def null(differences: list[float], jobs: int, margin: float | None) -> None:
    """The decide rule on a pair with no difference at all: ``jobs`` sequences of seeds drawn (with replacement,
    generator seeded 0) from a real pair's per-seed differences, centred on their mean."""
    centred = np.array(differences) - np.mean(differences)
    rng = np.random.default_rng(0)
    labels = ("a", "b")
    until = make_until({"decide": list(labels), "of": "final_utility", "max_seeds": 500, "block": 10,
                        **({} if margin is None else {"half_width": margin})}, labels)
    outcomes, used, covered = {}, [], 0
    for _ in range(jobs):
        draws = rng.choice(centred, until.max_seeds)
        verdict = None
        for seeds in range(until.block, until.max_seeds + 1, until.block):
            finals = {"a": dict(enumerate(draws[:seeds].tolist())), "b": dict.fromkeys(range(seeds), 0.0)}
            verdict = judge(until, finals, seeds)
            if verdict.reason is not None:
                break
        outcome = verdict.outcome or verdict.reason
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
        used.append(verdict.seeds)
        _, low, high = verdict.intervals["a - b"]
        covered += low <= 0.0 <= high
    print(f"decide, no difference (single's mgrao-max - mgrao-1:1 per-seed differences, centred, "
          f"{len(differences)} of them, drawn with replacement), margin {margin}: {jobs} sequences")
    low, high = wilson(covered, jobs)
    print(f"  the stopped interval holds 0: {covered / jobs:.3f} [{low:.3f}, {high:.3f}]")
    _report(outcomes, jobs, used)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs-single", type=int, default=200)
    parser.add_argument("--jobs-large", type=int, default=500)
    parser.add_argument("--decide-jobs", type=int, default=200)
    parser.add_argument("--null-jobs", type=int, default=2000)
    parser.add_argument("--half-width", type=float, default=2.0)
    parser.add_argument("--truth-seeds", type=int, default=5000)
    args = parser.parse_args()
    coverage("single", args.jobs_single, args.half_width, args.truth_seeds)
    coverage("large", args.jobs_large, args.half_width, args.truth_seeds)
    differences: list[float] = []
    decide("known difference", args.decide_jobs, args.truth_seeds, differences)
    decide("almost none", args.decide_jobs, args.truth_seeds)
    null(differences, args.null_jobs, None)
    null(differences, args.null_jobs, 2.0)


if __name__ == "__main__":
    main()
