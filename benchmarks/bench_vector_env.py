"""Learners at the engine's speed: the vector environment against the engine, parallel_env against its baseline.

    python benchmarks/bench_vector_env.py [--worlds 64] [--episodes 500] [--repeat 3] [--baseline DIR]

* **vector env / engine** (target >= 0.5), per system (single, multi, large): episodes per second of
  ``vector_env(system, seeds=range(W), episodes=E)`` stepped to truncation with fixed uniform actions
  (one array per child, built before timing), against the engine's ``run_experiment`` of ``uniform`` on
  the same W seeds and E episodes. Both in this process, compiled before timing, alternated, best of
  ``--repeat`` each; an episode is one world's episode.
* **parallel_env, now / before** (target >= 5), with ``--baseline DIR`` (a checkout of an earlier
  version, e.g. ``git worktree add /tmp/before 4abb38b``): episodes per second of ``parallel_env(system,
  episodes=1000)`` over 5 seeds with actions sampled from the action space (as benchmarks/bench_env.py:
  the issue's measure; the action space's ``sample`` is timed with it), then with one fixed uniform action
  (the environment's own cost), each a whole process on that checkout (``PYTHONPATH``), warmed up before
  timing, alternated, best of ``--repeat``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run as a script: find mgrao_core
import numpy as np  # noqa: E402

from benchmarks.bench_env import engine_round  # noqa: E402
from mgrao_core.env import vector_env  # noqa: E402

SYSTEMS = ("single", "multi", "large")
PARALLEL_SYSTEMS = ("single", "large")
PARALLEL_EPISODES, PARALLEL_SEEDS = 1000, 5
PARALLEL_ROUND = """
import sys, time
import numpy as np
from mgrao_core.env import parallel_env
def rate(system, seeds, episodes, sampled):
    env = parallel_env(system, episodes=episodes)
    fixed = {agent: np.full(env.params.n_types, 1.0 / env.params.n_types) for agent in env.possible_agents}
    for agent in env.possible_agents:
        env.action_space(agent).seed(0)
    started = time.perf_counter()
    for seed in range(seeds):
        env.reset(seed=seed)
        while env.agents:
            env.step({agent: env.action_space(agent).sample() for agent in env.agents} if sampled else fixed)
    return seeds * episodes / (time.perf_counter() - started)
rate(sys.argv[1], 1, 20, True)  # compile, or load the cache, before timing
print(rate(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4] == "sampled"))
"""


def vector_rate(system: str, worlds: int, episodes: int) -> float:
    env = vector_env(system, seeds=range(worlds), episodes=episodes)
    uniform = np.full((worlds, env.params.n_types), 1.0 / env.params.n_types)
    actions = dict.fromkeys(env.possible_agents, uniform)
    started = time.perf_counter()
    env.reset()
    while env.agents:
        env.step(actions)
    return worlds * episodes / (time.perf_counter() - started)


def parallel_rate(root: Path, system: str, actions: str) -> float:
    done = subprocess.run([sys.executable, "-c", PARALLEL_ROUND, system, str(PARALLEL_SEEDS), str(PARALLEL_EPISODES),
                           actions],
                          cwd=root, env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"}, capture_output=True,
                          text=True, check=True, timeout=900)
    return float(done.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=64)
    parser.add_argument("--episodes", type=int, default=500)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--baseline", type=Path, help="a checkout to compare parallel_env with")
    args = parser.parse_args()

    print(f"vector env ({args.worlds} worlds, fixed uniform actions) / engine uniform, {args.episodes} episodes, "
          f"best of {args.repeat} each, alternated; episodes per second")
    for system in SYSTEMS:
        vector_rate(system, 2, 3)
        engine_round(system, "uniform", 2, 3)  # compile, or load the cache, before timing
        vector, engine = [], []
        for _ in range(args.repeat):
            vector.append(vector_rate(system, args.worlds, args.episodes))
            engine.append(engine_round(system, "uniform", args.worlds, args.episodes))
        ratio = max(vector) / max(engine)
        print(f"  {system:7s} vector {max(vector):>10,.0f}  engine {max(engine):>10,.0f}  ratio {ratio:.2f} "
              f"(target >= 0.5: {'meets' if ratio >= 0.5 else 'MISSES'} it)")

    if args.baseline is None:
        return
    print(f"parallel_env, {PARALLEL_SEEDS} seeds x {PARALLEL_EPISODES} episodes, whole processes, best of "
          f"{args.repeat}, alternated: this checkout / {args.baseline}")
    for actions in ("sampled", "fixed"):
        for system in PARALLEL_SYSTEMS:
            now, before = [], []
            for _ in range(args.repeat):
                now.append(parallel_rate(ROOT, system, actions))
                before.append(parallel_rate(args.baseline, system, actions))
            ratio = max(now) / max(before)
            print(f"  {system:7s} {actions:7s} actions: now {max(now):>9,.0f}  before {max(before):>9,.0f}  "
                  f"ratio {ratio:.1f} (target >= 5: {'meets' if ratio >= 5 else 'MISSES'} it)")


if __name__ == "__main__":
    main()
