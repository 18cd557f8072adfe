"""Core benchmark: the paper reproduction's wall time, and how cost grows with size.

Run: ``python benchmarks/bench_core.py`` (add ``--quick`` for a shorter sweep). With
``--baseline DIR`` (a checkout of an earlier version, e.g. ``git worktree add /tmp/before 499d458``)
every point is measured there too, in the same run, and printed beside the current figure with
the ratio; a point the earlier version refuses (a limit it did not have) prints ``-``.

Every point runs in a fresh subprocess (after a warm-up call that loads the compiled kernel), so
its peak memory (max RSS) is its own. Throughput counts atomic tasks simulated per second:
seeds x algorithms x episodes x active parents x types per composite; each is one quality
evaluation, one value returned and (for MG-RAO) one algorithm-1 update. The start-up point instead
times ``python -m mgrao_cli reproduce --seeds 30`` as whole processes (interpreter, imports, loading
the cached kernel, simulation, exit), each checkout run from its own root.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import textwrap
import time

_POINT = textwrap.dedent(
    """
    import json, resource, sys, time
    from mgrao_core import make_spec, run_experiment
    from mgrao_core.reproduction import reproduce
    args = json.loads(sys.argv[1])
    run_experiment(make_spec("multi", seeds=1, episodes=2))  # load the compiled kernel
    extra = {}
    start = time.perf_counter()
    if args["what"] == "oracle":
        from mgrao_core.oracle import oracle_weights
        from mgrao_core.world import draw_world
        spec = make_spec(args["system"], ["oracle"], args["seeds"], 1, args["set"])
        small = make_spec("single", ["oracle"], 1, 1).params
        oracle_weights(small, draw_world(small, 0), 0)  # load its compiled code too
        checks = []
        start = time.perf_counter()
        for seed in spec.seeds:
            world = draw_world(spec.params, seed)
            oracle_weights(spec.params, world, seed, should_stop=lambda: checks.append(time.perf_counter()) or False)
        work = spec.params.n_parents * spec.params.types_per_composite * len(spec.seeds)  # one sample per seed
        ends = [start] + checks + [time.perf_counter()]
        extra = {"per_seed": (ends[-1] - start) / len(spec.seeds),
                 "longest_unchecked": max(b - a for a, b in zip(ends, ends[1:]))}
    elif args["what"] == "reproduce":
        results = reproduce(seeds=args["seeds"], episodes=args["episodes"])
        work = sum(r.spec.work for r in results.values())
    elif args["what"] == "reference":
        from mgrao_core.reference import simulate
        spec = make_spec(args["system"], seeds=args["seeds"], episodes=args["episodes"])
        for algorithm in spec.algorithms:
            for seed in spec.seeds:
                simulate(spec.params, algorithm, seed, spec.episodes)
        work = spec.work
    else:
        spec = make_spec(args["system"], args["algorithms"], args["seeds"], args["episodes"], args["set"])
        work = spec.work
        run_experiment(spec)
    wall = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"wall": wall, "work": work, "peak_mib": peak} | extra))
    """
)


BASELINE: str | None = None
"""A checkout of an earlier version to measure beside this one (``--baseline``)."""


def _run_point(args: dict, root: str | None) -> dict | None:
    env = dict(os.environ)
    if root is not None:
        env["PYTHONPATH"] = root
    out = subprocess.run(
        [sys.executable, "-c", _POINT, json.dumps(args)], capture_output=True, text=True, env=env, cwd=root
    )
    if out.returncode != 0:
        if root is None:
            raise RuntimeError(out.stderr)
        return None
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure(**args) -> dict:
    """Run one point in a fresh interpreter; returns wall seconds, atomic tasks and peak MiB.

    With a baseline, ``before`` holds the same point measured on it (None if it refused the point).
    """
    point = _run_point(args, None)
    if BASELINE is not None:
        point["before"] = _run_point(args, BASELINE)
    return point


def beside(point: dict, key: str = "wall") -> str:
    """The baseline's figure and the ratio now / before, or nothing without a baseline."""
    if BASELINE is None:
        return ""
    before = point.get("before")
    if before is None:
        return f" {'-':>9} {'-':>7}"
    return f" {before[key]:>9.3f} {point[key] / before[key]:>7.2f}"


def slope(xs: list[float], ys: list[float]) -> float:
    """Least-squares exponent of ``y ~ x**k`` over the points (log-log slope)."""
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly, strict=True)) / sum((a - mx) ** 2 for a in lx)


def sweep(title: str, name: str, values: list[int], build, explain: str) -> None:
    """Measure one axis, print a row per point and the fitted exponent of wall time."""
    print(f"\n{title}")
    extra = f" {'before s':>9} {'ratio':>7} {'before MiB':>10}" if BASELINE else ""
    print(f"{name:>10} {'wall s':>9} {'tasks/s':>12} {'peak MiB':>9}{extra}")
    walls, befores = [], []
    for value in values:
        point = measure(**build(value))
        walls.append(point["wall"])
        before = point.get("before")
        befores.append(before["wall"] if before else None)
        mib = f" {before['peak_mib']:>10.0f}" if before else (f" {'-':>10}" if BASELINE else "")
        print(
            f"{value:>10} {point['wall']:>9.3f} {point['work'] / point['wall']:>12.3g} {point['peak_mib']:>9.0f}"
            f"{beside(point)}{mib}"
        )
    line = f"  exponent of wall time: {slope(values, walls):.2f}"
    measured = [(v, b) for v, b in zip(values, befores, strict=True) if b is not None]
    if BASELINE and len(measured) >= 2:
        line += f" (before: {slope([v for v, _ in measured], [b for _, b in measured]):.2f})"
    print(f"{line} ({explain})")


ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STARTUP = ["-m", "mgrao_cli", "reproduce", "--seeds", "30"]
"""``mgrao reproduce --seeds 30``, run from a checkout's root (its packages first on the path)."""


def startup(runs: int = 11) -> None:
    """Whole processes of ``mgrao reproduce --seeds 30``, the kernel cached: medians of wall and CPU seconds.

    With a baseline the two checkouts run in turn (now, before, now, ...), so that a drift of the
    machine's speed reaches both, and the ratio is taken pair by pair.
    """
    roots = [ROOT] + ([BASELINE] if BASELINE else [])
    for root in roots:  # warm-up: load (or compile and store) each checkout's kernel
        subprocess.run([sys.executable, *STARTUP], cwd=root, capture_output=True, check=True)
    walls: dict[str, list[float]] = {root: [] for root in roots}
    cpus: dict[str, list[float]] = {root: [] for root in roots}
    for _ in range(runs):
        for root in roots:
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run([sys.executable, *STARTUP], cwd=root, capture_output=True, check=True)
            walls[root].append(time.perf_counter() - start)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus[root].append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    print(f"\nStart-up: `python {' '.join(STARTUP)}` as a whole process, the kernel cached, {runs} runs")
    now = statistics.median(walls[ROOT])
    line = f"  wall median {now:.3f} s (target: at most 0.8), CPU median {statistics.median(cpus[ROOT]):.3f} s"
    if BASELINE:
        ratios = [a / b for a, b in zip(walls[ROOT], walls[BASELINE], strict=True)]
        line += (f"; before: wall {statistics.median(walls[BASELINE]):.3f} s, CPU "
                 f"{statistics.median(cpus[BASELINE]):.3f} s; wall ratio now / before, median of pairs "
                 f"{statistics.median(ratios):.2f}")
    print(line)


def main() -> None:
    """Print the reproduction figures and the scaling sweeps."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sweeps")
    parser.add_argument("--baseline", metavar="DIR", help="a checkout of an earlier version to measure beside")
    options = parser.parse_args()
    quick = options.quick
    global BASELINE
    BASELINE = os.path.abspath(options.baseline) if options.baseline else None

    for seeds, target in ((100, "target: under 2 s"), (30, "")):
        print(f"Paper reproduction: 4 systems, the paper's algorithms, {seeds} seeds x 100 episodes, default reading")
        points = [measure(what="reproduce", seeds=seeds, episodes=100) for _ in range(5)]
        walls = sorted(p["wall"] for p in points)
        best = points[0]
        print(
            f"  wall median {walls[2]:.3f} s (min {walls[0]:.3f}, max {walls[-1]:.3f}) {target}; "
            f"{best['work']:,} atomic tasks, {best['work'] / walls[2]:.3g} tasks/s, peak {best['peak_mib']:.0f} MiB"
        )
        before = sorted(p["before"]["wall"] for p in points if p.get("before"))
        if before:
            print(
                f"  before: wall median {before[len(before) // 2]:.3f} s; "
                f"ratio of medians {walls[2] / before[len(before) // 2]:.2f} (target: at most 1.05)"
            )
    startup()
    ref = measure(what="reference", system="single", seeds=2, episodes=100)
    per_task = ref["wall"] / ref["work"]
    print(
        f"  dense per-agent reference (mgrao_core.reference) on single, 2 seeds: {ref['work'] / ref['wall']:.3g} "
        f"tasks/s; at that rate the reproduction would take about {per_task * best['work']:.0f} s"
    )

    print("\nOracle at 1,000 parents x 200 types per composite (large system), 2 seeds; beside it engine runs")
    size = {"n_parents": 1000, "n_types": 200, "types_per_composite": 200}
    oracle = measure(what="oracle", system="large", seeds=2, set=size)
    print(f"{'':>38} {'now':>9}" + (f" {'before':>9} {'ratio':>7}" if BASELINE else ""))
    print(f"{'oracle s per seed':>38} {oracle['per_seed']:>9.3f}{beside(oracle, 'per_seed')}")
    print(f"{'longest s between two stop checks':>38} {oracle['longest_unchecked']:>9.3f}"
          f"{beside(oracle, 'longest_unchecked')}  (target: under 0.5)")
    for algorithm in ("mgrao-1:1", "mgrao-max"):
        run = measure(what="run", system="large", algorithms=[algorithm], seeds=1, episodes=100, set=size)
        print(f"{algorithm + ' s, 1 seed x 100 episodes':>38} {run['wall']:>9.3f}{beside(run)}")

    def custom(parents: int, algorithms: list[str], seeds: int, episodes: int) -> dict:
        return {
            "what": "run",
            "system": "single",
            "algorithms": algorithms,
            "seeds": seeds,
            "episodes": episodes,
            "set": {"n_parents": parents, "n_composite_types": min(parents, 1000)},
        }

    top = 300 if quick else 1000
    parents = [10, 30, 100, 300] + ([] if quick else [1000])
    sweep(
        "Parents, mgrao-1:1 (one group), 4 seeds x 100 episodes",
        "parents",
        parents,
        lambda p: custom(p, ["mgrao-1:1"], 4, 100),
        "expected 1: each value updates one row",
    )
    sweep(
        "Parents, mgrao-max (a group per parent), 4 seeds x 100 episodes",
        "parents",
        parents,
        lambda p: custom(p, ["mgrao-max"], 4, 100),
        "P*5 values per episode, each renormalising the active rows (before: every row with a trace)",
    )
    sweep(
        "Many parents, mgrao-max, 4 seeds x 100 episodes",
        "parents",
        [300, 1000] + ([] if quick else [3000]),
        lambda p: custom(p, ["mgrao-max"], 4, 100),
        "target: at most 1.15, and under 0.5 s at 1,000 parents: an update visits only the active rows",
    )
    sweep(
        f"Groups at {top} parents, mgrao-x:1, 4 seeds x 100 episodes",
        "groups",
        [1, 10, 100] + ([] if quick else [1000]),
        lambda m: custom(top, [f"mgrao-{m}:1"], 4, 100),
        "expected at most 1: O(active rows) per value on top of O(1) per task",
    )
    sweep(
        "Episodes, single system, uniform + 1:1 + max, 4 seeds",
        "episodes",
        [100, 1000] + ([] if quick else [10000]),
        lambda e: {"what": "run", "system": "single", "algorithms": None, "seeds": 4, "episodes": e, "set": {}},
        "expected 1: constant work per episode",
    )
    sweep(
        "Seeds, single system, uniform + 1:1 + max, 100 episodes",
        "seeds",
        [4, 16, 64] + ([] if quick else [256]),
        lambda s: {"what": "run", "system": "single", "algorithms": None, "seeds": s, "episodes": 100, "set": {}},
        "expected 1 (below 1 until both cores are busy)",
    )


if __name__ == "__main__":
    main()
