"""Several resources: what each added resource costs in kernel time and in memory.

Run: ``python benchmarks/bench_resources.py [--seeds 20] [--repeats 5]``. For 1, 2, 4 and 8 resources, each in a
fresh subprocess after a warm-up that loads (or compiles) the kernel: ``large`` (50 parents, one child) with
uniform, mgrao-1:1 and mgrao-max (MG-RAO keeps a PW per resource), 100 episodes, under ``resource_credit =
by-share`` (the costlier credit: each resource's PW learns its own share), on one numba thread. Prints the
median CPU time (the work: what a loaded machine's wall time hides) and wall time of ``run_experiment``, the
peak of the memory numpy allocates while it runs (``tracemalloc``, which sees every array the runner and the
budget count) and the budget's own count (``chunk_cost``), then the cost of each added resource as a multiple
of the single-resource run: ``(value(R) - value(1)) / ((R - 1) * value(1))``. The target: at most 1 (each
added resource costs at most the single-resource run again).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import textwrap

_POINT = textwrap.dedent(
    """
    import json, sys, time, tracemalloc
    from mgrao_core import make_spec, run_experiment
    from mgrao_core.budget import chunk_cost
    args = json.loads(sys.argv[1])
    overrides = {"n_resources": args["resources"]}
    if args["resources"] > 1:
        overrides["resource_credit"] = "by-share"
    run_experiment(make_spec("large", ["uniform", "mgrao-1:1", "mgrao-max"], seeds=1, episodes=2,
                             overrides=overrides))  # load the compiled kernel
    spec = make_spec("large", ["uniform", "mgrao-1:1", "mgrao-max"], seeds=args["seeds"], episodes=100,
                     overrides=overrides)
    times, cpu = [], []
    for _ in range(args["repeats"]):
        start, start_cpu = time.perf_counter(), time.process_time()
        run_experiment(spec)
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    tracemalloc.start()
    run_experiment(spec)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    print(json.dumps({"wall": sorted(times)[len(times) // 2], "seconds": sorted(cpu)[len(cpu) // 2], "peak": peak,
                      "counted": chunk_cost(spec, len(spec.seeds)).total}))
    """
)
RESOURCES = (1, 2, 4, 8)


def measure(resources: int, seeds: int, repeats: int) -> dict:
    """One point in a fresh interpreter of this checkout."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root, "NUMBA_NUM_THREADS": "1"}  # one thread: CPU time is the work
    out = subprocess.run([sys.executable, "-c", _POINT, json.dumps({"resources": resources, "seeds": seeds,
                                                                    "repeats": repeats})],
                         env=env, check=True, capture_output=True, text=True, cwd=root)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    points = {r: measure(r, args.seeds, args.repeats) for r in RESOURCES}
    base = points[1]
    print(f"large, uniform + mgrao-1:1 + mgrao-max, {args.seeds} seeds x 100 episodes, median of {args.repeats}")
    print(f"{'resources':>9} {'CPU (s)':>8} {'wall (s)':>9} {'peak (MiB)':>11} {'counted (MiB)':>14} "
          f"{'CPU/added':>10} {'peak/added':>11}")
    for r, point in points.items():
        added = [(point[k] - base[k]) / ((r - 1) * base[k]) if r > 1 else float("nan") for k in ("seconds", "peak")]
        print(f"{r:>9} {point['seconds']:>8.3f} {point['wall']:>9.3f} {point['peak'] / 2**20:>11.1f} "
              f"{point['counted'] / 2**20:>14.1f} {added[0]:>10.2f} {added[1]:>11.2f}")
    worst = max((points[r][k] - base[k]) / ((r - 1) * base[k]) for r in RESOURCES[1:] for k in ("seconds", "peak"))
    print(f"worst cost of an added resource: {worst:.2f} x the single-resource run (target: at most 1)")


if __name__ == "__main__":
    main()
