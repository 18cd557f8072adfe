"""Benchmark of the PettingZoo environment: episodes per second with a random policy (target >= 2,000).

    python benchmarks/bench_env.py [--system single] [--episodes 1000] [--seeds 5] [--repeat 5]

In one process: ``mgrao_core.env.parallel_env(system, episodes=E)``, each of ``--seeds`` seeds reset
and stepped to truncation with actions drawn uniformly from each child's action space (a random
policy; drawing them is timed too, as a learner's policy would be). Prints each round's episodes per
second of wall-clock time (the target's) and per second of the process's CPU time (what a busy
machine does not take away), and their medians; then, for comparison, the engine's episodes per
second for the same system, seeds and episodes (``run_experiment`` of ``uniform`` and of
``mgrao-max``, compiled before timing, one lane per seed, on the threads numba is given:
``NUMBA_NUM_THREADS``).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run as a script: find mgrao_core
from mgrao_core import make_spec, run_experiment  # noqa: E402
from mgrao_core.env import parallel_env  # noqa: E402

TARGET = 2_000


def env_round(system: str, seeds: int, episodes: int) -> tuple[float, float]:
    """Episodes per second of wall-clock time and of this process's CPU time."""
    env = parallel_env(system, episodes=episodes)
    for agent in env.possible_agents:
        env.action_space(agent).seed(0)
    started, cpu = time.perf_counter(), time.process_time()
    for seed in range(seeds):
        env.reset(seed=seed)
        while env.agents:
            env.step({agent: env.action_space(agent).sample() for agent in env.agents})
    n = seeds * episodes
    return n / (time.perf_counter() - started), n / (time.process_time() - cpu)


def engine_round(system: str, algorithm: str, seeds: int, episodes: int) -> float:
    spec = make_spec(system, [algorithm], seeds, episodes)
    started = time.perf_counter()
    run_experiment(spec)
    return seeds * episodes / (time.perf_counter() - started)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--system", default="single")
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()

    print(f"{args.system}: {args.seeds} seeds x {args.episodes} episodes, random policy, one process")
    rates, cpu_rates = [], []
    for i in range(args.repeat):
        wall, cpu = env_round(args.system, args.seeds, args.episodes)
        rates.append(wall)
        cpu_rates.append(cpu)
        print(f"  env round {i + 1}: {wall:,.0f} episodes/s ({cpu:,.0f} per CPU second)")
    env_rate = statistics.median(rates)
    verdict = "meets" if env_rate >= TARGET else "MISSES"
    print(f"env: {env_rate:,.0f} episodes/s, {statistics.median(cpu_rates):,.0f} per CPU second "
          f"(medians of {args.repeat}; target >= {TARGET:,}: {verdict} it)")

    for algorithm in ("uniform", "mgrao-max"):
        engine_round(args.system, algorithm, 1, 10)  # compile (or load the cache) before timing
        engine = statistics.median(engine_round(args.system, algorithm, args.seeds, args.episodes)
                                   for _ in range(args.repeat))
        print(f"engine, {algorithm}: {engine:,.0f} episodes/s "
              f"(median of {args.repeat}; {engine / env_rate:,.0f}x the env)")


if __name__ == "__main__":
    main()
