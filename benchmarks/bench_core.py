"""Core benchmark: the paper reproduction's wall time, and how cost grows with size.

Run: ``python benchmarks/bench_core.py`` (add ``--quick`` for a shorter sweep).

Every point runs in a fresh subprocess (after a warm-up call that loads the compiled kernel), so
its peak memory (max RSS) is its own. Throughput counts atomic tasks simulated per second:
seeds x algorithms x episodes x active parents x types per composite; each is one quality
evaluation, one value returned and (for MG-RAO) one algorithm-1 update.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import textwrap

_POINT = textwrap.dedent(
    """
    import json, resource, sys, time
    from mgrao_core import make_spec, run_experiment
    from mgrao_core.reproduction import reproduce
    args = json.loads(sys.argv[1])
    run_experiment(make_spec("multi", seeds=1, episodes=2))  # load the compiled kernel
    start = time.perf_counter()
    if args["what"] == "reproduce":
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
    print(json.dumps({"wall": wall, "work": work, "peak_mib": peak}))
    """
)


def measure(**args) -> dict:
    """Run one point in a fresh interpreter; returns wall seconds, atomic tasks and peak MiB."""
    out = subprocess.run([sys.executable, "-c", _POINT, json.dumps(args)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def slope(xs: list[float], ys: list[float]) -> float:
    """Least-squares exponent of ``y ~ x**k`` over the points (log-log slope)."""
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly, strict=True)) / sum((a - mx) ** 2 for a in lx)


def sweep(title: str, name: str, values: list[int], build, explain: str) -> None:
    """Measure one axis, print a row per point and the fitted exponent of wall time."""
    print(f"\n{title}")
    print(f"{name:>10} {'wall s':>9} {'tasks/s':>12} {'peak MiB':>9}")
    walls = []
    for value in values:
        point = measure(**build(value))
        walls.append(point["wall"])
        print(f"{value:>10} {point['wall']:>9.3f} {point['work'] / point['wall']:>12.3g} {point['peak_mib']:>9.0f}")
    print(f"  exponent of wall time: {slope(values, walls):.2f} ({explain})")


def main() -> None:
    """Print the reproduction figures and the scaling sweeps."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sweeps")
    quick = parser.parse_args().quick

    for seeds, target in ((100, "target: under 2 s"), (30, "")):
        print(f"Paper reproduction: 4 systems, the paper's algorithms, {seeds} seeds x 100 episodes, default reading")
        points = [measure(what="reproduce", seeds=seeds, episodes=100) for _ in range(5)]
        walls = sorted(p["wall"] for p in points)
        best = points[0]
        print(
            f"  wall median {walls[2]:.3f} s (min {walls[0]:.3f}, max {walls[-1]:.3f}) {target}; "
            f"{best['work']:,} atomic tasks, {best['work'] / walls[2]:.3g} tasks/s, peak {best['peak_mib']:.0f} MiB"
        )
    ref = measure(what="reference", system="single", seeds=2, episodes=100)
    per_task = ref["wall"] / ref["work"]
    print(
        f"  dense per-agent reference (mgrao_core.reference) on single, 2 seeds: {ref['work'] / ref['wall']:.3g} "
        f"tasks/s; at that rate the reproduction would take about {per_task * best['work']:.0f} s"
    )

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
        "expected 2: P*5 values per episode, each renormalising all P rows with a positive trace",
    )
    sweep(
        f"Groups at {top} parents, mgrao-x:1, 4 seeds x 100 episodes",
        "groups",
        [1, 10, 100] + ([] if quick else [1000]),
        lambda m: custom(top, [f"mgrao-{m}:1"], 4, 100),
        "expected up to 1: O(groups) per value on top of O(1) per task",
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
