"""Kernel time of the standard learners against MG-RAO (issue 21's speed target).

Run: ``python benchmarks/bench_learners.py`` (about two minutes on 2 cores; ``--seeds``,
``--episodes``, ``--repeats``, ``--system`` to change the point).

The target: on ``large``, 1,000 seeds x 100 episodes (so that noise does not decide), each new
algorithm's kernel time within 2x of ``mgrao-1:1``'s. Each algorithm runs alone in its experiment;
the time counted is the compiled kernel's (``engine.run_block`` and ``engine.finish``, timed around
the runner's calls), not the drawing of worlds and episode randomness that every algorithm shares.
The algorithms take turns, ``--repeats`` rounds, and the median of each is reported: the machine is
shared, so a single timing can be off by tens of percent.
"""

from __future__ import annotations

import argparse
import statistics
import time

from mgrao_core import engine, make_spec, run_experiment

ALGORITHMS = ("mgrao-1:1", "independent-q", "bandit", "mgrao-max")
TARGET = 2.0


def kernel_seconds(spec) -> float:
    """Seconds spent in the kernel (``run_block`` and ``finish``) while ``spec`` runs."""
    spent = [0.0]
    run_block, finish = engine.run_block, engine.finish

    def timed(function):
        def call(*args):
            start = time.perf_counter()
            function(*args)
            spent[0] += time.perf_counter() - start
        return call

    engine.run_block, engine.finish = timed(run_block), timed(finish)
    try:
        run_experiment(spec)
    finally:
        engine.run_block, engine.finish = run_block, finish
    return spent[0]


def main() -> None:
    """Time every algorithm, ``--repeats`` rounds, and print medians and ratios to mgrao-1:1."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--system", default="large")
    parser.add_argument("--seeds", type=int, default=1000)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    run_experiment(make_spec("multi", list(ALGORITHMS[:3]), seeds=1, episodes=2))  # load the compiled kernel
    times: dict[str, list[float]] = {a: [] for a in ALGORITHMS}
    for _ in range(args.repeats):
        for algorithm in ALGORITHMS:
            spec = make_spec(args.system, [algorithm], seeds=args.seeds, episodes=args.episodes)
            times[algorithm].append(kernel_seconds(spec))
    base = statistics.median(times["mgrao-1:1"])
    print(f"kernel time, {args.system}: {args.seeds} seeds x {args.episodes} episodes, "
          f"median of {args.repeats} (every timing in brackets)")
    print(f"{'algorithm':<15}{'seconds':>10}{'x mgrao-1:1':>13}  timings")
    for algorithm, values in times.items():
        median = statistics.median(values)
        verdict = "" if algorithm.startswith("mgrao") else ("  within 2x" if median <= TARGET * base else "  OVER 2x")
        print(f"{algorithm:<15}{median:>10.2f}{median / base:>13.2f}  [{', '.join(f'{v:.2f}' for v in values)}]"
              f"{verdict}")


if __name__ == "__main__":
    main()
