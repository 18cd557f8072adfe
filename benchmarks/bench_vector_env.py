"""Learners at the engine's speed: the vector environment against the engine, parallel_env against its baseline.

    python benchmarks/bench_vector_env.py [--worlds 64] [--episodes 500] [--repeat 3] [--baseline DIR]

* **vector env / engine** (target >= 0.5), per system (single, multi, large), with autoreset on: episodes per
  second of ``vector_env(system, seeds=range(W), episodes=E)`` with fixed uniform actions (one array per child,
  built before timing), reset, then stepped through two runs of every world, the worlds starting afresh between
  them by autoreset (next-step: ``2 E + 1`` steps, the step between them playing no episode; same-step: ``2 E``
  steps), against the engine's ``run_experiment`` of ``uniform`` on the same W seeds and E episodes. All in this
  process, compiled before timing, alternated, best of ``--repeat`` each; an episode is one world's episode. The
  machine's load average (1 minute) is printed before and after: on a shared machine the ratios move with it.
* **parallel_env, now / before** (target >= 5), with ``--baseline DIR`` (a checkout of an earlier
  version, e.g. ``git worktree add /tmp/before 4abb38b``): episodes per second of ``parallel_env(system,
  episodes=1000)`` over 5 seeds with actions sampled from the action space (as benchmarks/bench_env.py:
  the issue's measure; the action space's ``sample`` is timed with it), then with one fixed uniform action
  (the environment's own cost), each a whole process on that checkout (``PYTHONPATH``), warmed up before
  timing, alternated, best of ``--repeat``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run as a script: find mgrao_core
import numpy as np  # noqa: E402
from gymnasium.vector import AutoresetMode  # noqa: E402

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


def vector_rate(system: str, worlds: int, episodes: int, mode: AutoresetMode) -> float:
    env = vector_env(system, seeds=range(worlds), episodes=episodes, autoreset_mode=mode)
    uniform = np.full((worlds, env.params.n_types), 1.0 / env.params.n_types)
    actions = dict.fromkeys(env.possible_agents, uniform)
    steps = 2 * episodes + (mode is AutoresetMode.NEXT_STEP)
    started = time.perf_counter()
    env.reset()
    for _ in range(steps):
        env.step(actions)
    elapsed = time.perf_counter() - started
    assert (env.world_episodes == (episodes if mode is AutoresetMode.NEXT_STEP else 0)).all()  # two whole runs
    return 2 * worlds * episodes / elapsed


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

    print(f"vector env ({args.worlds} worlds, fixed uniform actions, two runs of {args.episodes} episodes with "
          f"autoreset) / engine uniform ({args.episodes} episodes), best of {args.repeat} each, alternated; episodes "
          f"per second; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    modes = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP)
    for system in SYSTEMS:
        for mode in modes:
            vector_rate(system, 2, 3, mode)
        engine_round(system, "uniform", 2, 3)  # compile, or load the cache, before timing
        vector: dict[AutoresetMode, list[float]] = {mode: [] for mode in modes}
        engine = []
        for _ in range(args.repeat):
            for mode in modes:
                vector[mode].append(vector_rate(system, args.worlds, args.episodes, mode))
            engine.append(engine_round(system, "uniform", args.worlds, args.episodes))
        for mode in modes:
            ratio = max(vector[mode]) / max(engine)
            print(f"  {system:7s} {mode.value:9s} vector {max(vector[mode]):>10,.0f}  engine {max(engine):>10,.0f}  "
                  f"ratio {ratio:.2f} (target >= 0.5: {'meets' if ratio >= 0.5 else 'MISSES'} it)")
    print(f"load average {os.getloadavg()[0]:.1f}")

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
