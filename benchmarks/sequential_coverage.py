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
* **joint coverage** (``--joint-jobs``, default 1,000): single's two learners judged by the half_width rule,
  each job evaluated under the per-configuration rule and under ``joint`` (each interval at 1 - 0.05/2) on the
  same seeds; printed: how often *both* intervals hold their truth at once (Wilson 95% interval; target: point
  at least 0.94) and the seeds each rule used.
* **decide rule with no difference at all**, on seven pairs of real per-seed differences (``PAIRS``: five
  systems, skewness -0.6 to 4.7): ``--null-jobs`` sequences (default 2,000) drawn with replacement from the
  pair's 5,000 per-seed differences, centred (a real distribution whose mean is exactly 0), judged block by
  block as a job judges them, without a margin (every decision is false) and with a margin of 2; each under
  the decide rule's confidence sequence and under the one it replaced (``before``: the asymptotic normal
  mixture), with the seeds each used; then the same pairs uncentred (their real differences), for the seeds
  a decision costs.

The ``--parts`` option runs some of these only (``coverage,decide,joint,null``).
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
from mgrao_core.statistics.confidence_sequence import cs_half_width, mixture_variance  # noqa: E402
from mgrao_core.statistics.sequential import MIN_SEEDS, judge, judged_values, make_until, run_until  # noqa: E402

TRUTH_FIRST, JOBS_FIRST, DECIDE_FIRST = 100_000_000, 1_000_000, 50_000_000
SYSTEMS = {"single": ("uniform", "mgrao-1:1", "mgrao-max"),
           "large": ("uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max")}
DECIDE = {"known difference": ("single", ("uniform", "mgrao-1:1", "mgrao-max"), ("mgrao-max", "mgrao-1:1")),
          "almost none": ("large", ("uniform", "mgrao-10:1", "mgrao-25:1"), ("mgrao-10:1", "mgrao-25:1"))}
EPISODES = 100
PAIRS = (("single", ("uniform", "mgrao-1:1", "mgrao-max"), ("mgrao-max", "mgrao-1:1")),
         ("multi", ("uniform", "mgrao-1:1", "mgrao-max"), ("mgrao-max", "mgrao-1:1")),
         ("large", ("uniform", "mgrao-10:1", "mgrao-25:1"), ("mgrao-10:1", "mgrao-25:1")),
         ("large", ("uniform", "mgrao-1:1", "mgrao-max"), ("mgrao-max", "mgrao-1:1")),
         ("volatile", ("uniform", "mgrao-1:1", "mgrao-max"), ("mgrao-max", "mgrao-1:1")),
         ("cloud", ("uniform", "mgrao-1:1", "independent-q"), ("mgrao-1:1", "independent-q")),
         ("cloud", ("uniform", "mgrao-1:1", "mgrao-max"), ("mgrao-max", "mgrao-1:1")))
"""Real pairs whose per-seed differences the decide rule is judged on (system, algorithms run, the pair)."""


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


def before_half_width(sd: float, n: int) -> float:
    """The decide rule's boundary before Lai's sequential t: the asymptotic normal mixture, sd plugged in."""
    r = mixture_variance()
    return sd * math.sqrt(2.0 * (n * r + 1.0) / (n * n * r) * math.log(math.sqrt(n * r + 1.0) / 0.05))


def sequences(differences: np.ndarray, jobs: int, margin: float | None, half_width, *, max_seeds: int = 500,
              block: int = 10, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The decide rule's outcome (1: A, -1: B, 2: equivalent, 0: none) and seeds of ``jobs`` sequences drawn with
    replacement from ``differences``, judged after every block as :func:`judge` judges (``half_width(sd, n)``)."""
    draws = np.random.default_rng(seed).choice(differences, size=(jobs, max_seeds))
    sums, squares = np.cumsum(draws, axis=1), np.cumsum(draws * draws, axis=1)
    outcome, used = np.zeros(jobs, dtype=int), np.full(jobs, max_seeds)
    running = np.ones(jobs, dtype=bool)
    for n in range(block, max_seeds + 1, block):
        if n < MIN_SEEDS:
            continue
        mean = sums[:, n - 1] / n
        sd = np.sqrt(np.maximum(squares[:, n - 1] - n * mean * mean, 0.0) / (n - 1))
        half = np.array([half_width(s, n) for s in sd])
        low, high = mean - half, mean + half
        a, b = running & (low > 0), running & (high < 0)
        same = running & ~a & ~b & (margin is not None) & (low > -(margin or 0)) & (high < (margin or 0))
        outcome[a], outcome[b], outcome[same] = 1, -1, 2
        stopped = a | b | same
        used[stopped] = n
        running &= ~stopped
    return outcome, used


def null(pools: dict[tuple[str, str, str], np.ndarray], jobs: int) -> None:
    """The decide rule on pairs with no difference at all: each pair's per-seed differences, centred."""
    from scipy.stats import kurtosis, skew

    print(f"decide, no difference: {jobs} sequences per pair and rule, drawn with replacement from each pair's "
          f"centred per-seed differences; blocks of 10, at most 500 seeds")
    print(f"  {'pair':38s} {'skew':>5s} {'kurt':>5s} {'margin':>6s}  {'rule':6s} {'false decisions':24s} "
          f"{'A':>6s} {'B':>6s} {'seeds':>6s}")
    for (system, a, b), d in pools.items():
        centred = d - d.mean()
        for margin in (None, 2.0):
            for name, boundary in (("now", cs_half_width), ("before", before_half_width)):
                outcome, used = sequences(centred, jobs, margin, boundary)
                wrong = int(np.sum((outcome == 1) | (outcome == -1)))
                low, high = wilson(wrong, jobs)
                print(f"  {system + ' ' + a + ' - ' + b:38s} {skew(d):5.2f} {kurtosis(d):5.1f} {str(margin):>6s}  "
                      f"{name:6s} {wrong / jobs:.3f} [{low:.3f}, {high:.3f}]     {np.mean(outcome == 1):6.3f} "
                      f"{np.mean(outcome == -1):6.3f} {used.mean():6.1f}")
    print(f"decide, the real differences (uncentred): {jobs} sequences per pair, margin 2; outcomes and seeds")
    for (system, a, b), d in pools.items():
        for name, boundary in (("now", cs_half_width), ("before", before_half_width)):
            outcome, used = sequences(d, jobs, 2.0, boundary, seed=1)
            print(f"  {system + ' ' + a + ' - ' + b:38s} mean {d.mean():+6.2f}  {name:6s} "
                  f"A {np.mean(outcome == 1):.3f} "
                  f"B {np.mean(outcome == -1):.3f} equivalent {np.mean(outcome == 2):.3f}  seeds: mean "
                  f"{used.mean():.1f}, median {np.median(used):.0f}")


def pair_pools(truth_seeds: int) -> dict[tuple[str, str, str], np.ndarray]:
    """Each pair's per-seed differences in % from uniform over ``truth_seeds`` seeds."""
    pools = {}
    for system, algorithms, pair in PAIRS:
        differences: list[float] = []
        truth(system, algorithms, truth_seeds, pair, differences)
        pools[(system, *pair)] = np.array(differences)
    return pools


def joint(jobs: int, half_width: float, truth_seeds: int) -> None:
    """Joint coverage of single's two learners under the per-configuration rule and under ``joint``."""
    system, algorithms = "single", SYSTEMS["single"]
    started = time.perf_counter()
    true = truth(system, algorithms, truth_seeds)
    rules = {"per configuration": make_until({"half_width": half_width}, algorithms),
             "joint": make_until({"half_width": half_width, "joint": True}, algorithms)}
    both = {name: 0 for name in rules}
    used: dict[str, list[int]] = {name: [] for name in rules}
    for k in range(jobs):
        first, finals, seeds = JOBS_FIRST + 500 * k, {a: {} for a in algorithms}, 0
        verdicts = dict.fromkeys(rules)
        while any(v is None for v in verdicts.values()):
            chunk = list(range(first + seeds, first + seeds + 50))
            result = run_experiment(make_spec(system, list(algorithms), chunk, EPISODES))
            for a in algorithms:
                finals[a].update(zip(chunk, final_utilities(result.utilities(a)).tolist(), strict=True))
            for n in range(seeds + 10, seeds + 51, 10):
                for name, until in rules.items():
                    if verdicts[name] is None:
                        verdict = judge(until, {a: {s: finals[a][s] for s in range(first, first + n)}
                                                for a in algorithms}, n)
                        if verdict.reason is not None:
                            verdicts[name] = verdict
            seeds += 50
        for name, verdict in verdicts.items():
            used[name].append(verdict.seeds)
            both[name] += all(low <= true[label] <= high for label, (_, low, high) in verdict.intervals.items())
    print(f"joint coverage, {system} {', '.join(rules['joint'].judge)} judged, half_width {half_width}: {jobs} jobs "
          f"({time.perf_counter() - started:.0f} s)")
    for name in rules:
        low, high = wilson(both[name], jobs)
        print(f"  {name:18s} both hold {both[name] / jobs:.3f} [{low:.3f}, {high:.3f}]; seeds used: mean "
              f"{statistics.fmean(used[name]):.1f}, median {statistics.median(used[name]):.0f}, largest "
              f"{max(used[name])}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--jobs-single", type=int, default=200)
    parser.add_argument("--jobs-large", type=int, default=500)
    parser.add_argument("--decide-jobs", type=int, default=200)
    parser.add_argument("--null-jobs", type=int, default=2000)
    parser.add_argument("--joint-jobs", type=int, default=1000)
    parser.add_argument("--parts", default="coverage,decide,joint,null")
    parser.add_argument("--half-width", type=float, default=2.0)
    parser.add_argument("--truth-seeds", type=int, default=5000)
    args = parser.parse_args()
    parts = set(args.parts.split(","))
    if "coverage" in parts:
        coverage("single", args.jobs_single, args.half_width, args.truth_seeds)
        coverage("large", args.jobs_large, args.half_width, args.truth_seeds)
    if "decide" in parts:
        decide("known difference", args.decide_jobs, args.truth_seeds)
        decide("almost none", args.decide_jobs, args.truth_seeds)
    if "joint" in parts:
        joint(args.joint_jobs, args.half_width, args.truth_seeds)
    if "null" in parts:
        null(pair_pools(args.truth_seeds), args.null_jobs)


if __name__ == "__main__":
    main()
