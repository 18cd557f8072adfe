"""MG-RAO at scale: a sparse world of 10,000 children and 100,000 parents, its cost per link and its physical bound.

    python benchmarks/bench_scale.py [--episodes 100] [--topology ring] [--part target,links,bound]

* **target**: one seed of ``mgrao-100:1`` for ``--episodes`` episodes on 10,000 children and 100,000 parents, each
  parent offering its tasks to 8 children (``topology`` ring by default, or random), run as ``mgrao run`` runs it
  (``run_experiment``) in a process of its own: its wall time and the peak resident memory of the whole process
  (``ru_maxrss`` of the child). Targets: at most 60 s and 4 GiB.
* **links**: the kernel's time per episode (the median over episodes after the first of ``engine.run_block`` called
  one episode at a time, warm) from 1,000 to 100,000 parents at 8 children each (children a tenth of the parents,
  ``mgrao-100:1``), and the slope of a log-log fit of time against links (1: linear); the ratio of the largest to the
  smallest against the ratio of their links (target: within 1.5x of linear).
* **bound**: the bytes one episode must touch at the target's size (every child's PW rows read for its allocation,
  its counts and row dkls; the returned values' active rows; the parents' estimates and tries; the episode's draws
  and each task's value, quality and child), against this machine's memory bandwidth measured by a streaming copy
  of 512 MiB; the kernel's time per episode as a multiple of that bound (aim: at most 5x).
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

TARGET = {"n_children": 10_000, "n_parents": 100_000, "children_per_parent": 8}
LABEL = "mgrao-100:1"


def _overrides(topology: str, parents: int, children: int) -> dict:
    return {"n_children": children, "n_parents": parents, "topology": topology, "children_per_parent": 8}


def run_target(episodes: int, topology: str) -> dict:
    """The target run in this process (what the child process of :func:`target` executes)."""
    from mgrao_core import make_spec, run_experiment

    began = time.perf_counter()
    spec = make_spec("multi", [LABEL], [0], episodes, _overrides(topology, TARGET["n_parents"], TARGET["n_children"]))
    result = run_experiment(spec)
    return {"seconds": time.perf_counter() - began, "final": float(result.runs[0].utilities[-10:].mean())}


def target(episodes: int, topology: str) -> None:
    began = time.perf_counter()
    done = subprocess.run([sys.executable, __file__, "--child", str(episodes), topology], capture_output=True,
                          text=True, check=True, timeout=3600)
    wall = time.perf_counter() - began
    inside = json.loads(done.stdout.strip().splitlines()[-1])
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
    print(f"target: {LABEL}, 10,000 children x 100,000 parents, 8 children per parent ({topology}), one seed, "
          f"{episodes} episodes")
    print(f"  whole process: {wall:.1f} s wall (target 60 s), peak resident {peak / 2**30:.2f} GiB (target 4 GiB); "
          f"run_experiment {inside['seconds']:.1f} s; final utility {inside['final']:.1f}")


def kernel_seconds(parents: int, children: int, topology: str, episodes: int, label: str = LABEL) -> float:
    """The median kernel time per episode (after the first) of ``label`` (``mgrao-100:1``) at this size."""
    from mgrao_core import engine, make_spec, runner

    spec = make_spec("multi", [label], [0], episodes, _overrides(topology, parents, children))
    timed = []
    original = engine.run_block

    def timing(*args):
        started = time.perf_counter()
        original(*args)
        timed.append(time.perf_counter() - started)

    engine.run_block = timing
    try:
        runner.run_chunk(spec, [0], episodes_per_block=1)
    finally:
        engine.run_block = original
    return statistics.median(timed[1:])


def links(topology: str, episodes: int) -> None:
    sizes = [1_000, 3_000, 10_000, 30_000, 100_000]
    kernel_seconds(sizes[0], sizes[0] // 10, topology, 3)  # compiled (or loaded) before anything is timed
    times = [kernel_seconds(p, p // 10, topology, episodes) for p in sizes]
    counts = [8 * p for p in sizes]
    slope = np.polyfit(np.log(counts), np.log(times), 1)[0]
    print(f"links: {LABEL}, 8 children per parent ({topology}), children a tenth of the parents; kernel time per "
          f"episode (median of {episodes - 1})")
    for p, n, t in zip(sizes, counts, times, strict=True):
        print(f"  {p:>7,} parents, {p // 10:>6,} children, {n:>9,} links: {1000 * t:8.2f} ms  "
              f"({1e9 * t / n:.0f} ns a link)")
    ratio = (times[-1] / times[0]) / (counts[-1] / counts[0])
    print(f"  log-log slope {slope:.3f} (1: linear); largest/smallest {times[-1] / times[0]:.1f}x for "
          f"{counts[-1] / counts[0]:.0f}x the links: {ratio:.2f}x linear (target within 1.5x)")


def bandwidth() -> float:
    """Bytes per second of a streaming copy (read and write) of 512 MiB, the best of five."""
    source = np.ones(2**26)
    target_ = np.empty_like(source)
    best = math.inf
    for _ in range(5):
        started = time.perf_counter()
        np.copyto(target_, source)
        best = min(best, time.perf_counter() - started)
    return 2 * source.nbytes / best


def episode_bytes(topology: str) -> int:
    """What one episode of the target must read or write at least, in bytes."""
    from mgrao_core import make_params
    from mgrao_core.algorithms.state import routing_choices

    p = make_params(_overrides(topology, TARGET["n_parents"], TARGET["n_children"]))
    f, m = 8, 100
    children, parents, tpc, n = p.n_children, p.n_parents, p.types_per_composite, p.n_types
    allocation = children * m * (n + 2) * f + children * n * f  # PW rows, counts and row dkls read; weights written
    learning = parents * tpc * 6 * f  # per returned value: its PW entry and trace, the active row's H, cs, G
    estimates = parents * routing_choices(p) * 8 * 2 * f  # the parents' estimates and tries of their links
    draws = parents * (tpc + 1 + 1 + routing_choices(p) * 3) * f  # value noise, order, volatility, routing
    tasks = parents * tpc * 4 * f  # proportional values, child, quality, absolute value
    return allocation + learning + estimates + draws + tasks


def bound(topology: str, episodes: int) -> None:
    rate = bandwidth()
    needed = episode_bytes(topology)
    seconds = kernel_seconds(TARGET["n_parents"], TARGET["n_children"], topology, episodes)
    floor = needed / rate
    print(f"bound: one episode of the target touches at least {needed / 2**20:.0f} MiB; a streaming copy moves "
          f"{rate / 2**30:.1f} GiB/s here, so {1000 * floor:.1f} ms; the kernel takes {1000 * seconds:.1f} ms: "
          f"{seconds / floor:.1f}x the bound (aim: at most 5x)")


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        print(json.dumps(run_target(int(sys.argv[2]), sys.argv[3])))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--topology", choices=("ring", "random"), default="ring")
    parser.add_argument("--part", default="target,links,bound")
    args = parser.parse_args()
    parts = set(args.part.split(","))
    if "target" in parts:
        target(args.episodes, args.topology)
    if "links" in parts:
        links(args.topology, min(args.episodes, 12))
    if "bound" in parts:
        bound(args.topology, min(args.episodes, 12))


if __name__ == "__main__":
    main()
