"""The independent learner of examples/independent_learner.py, trained through SuperSuit's vector conversion.

    pip install "mgrao[env]" supersuit   # or, in a clone: pip install -e ".[test]" (it includes SuperSuit)
    mgrao serve &                         # or any running service
    python examples/supersuit_learner.py [--url http://127.0.0.1:8000] [--token T] [--seeds 30]
                                         [--episodes 100] [--label value-prop-ss] [--system single]

SuperSuit (Farama's wrappers for PettingZoo and Gymnasium, numpy only) turns a PettingZoo ``ParallelEnv`` into a
vector environment whose rows are its agents (``pettingzoo_env_to_vec_env_v1``) and concatenates copies of it
(``concat_vec_envs_v1``): here ``--seeds`` copies of :func:`mgrao_core.env.parallel_env`, reset with seed 0 (copy
``i``: the engine's seed ``i``), stepped together, one row per child of each copy. Each row's learner is
:class:`ValueProportional` of examples/independent_learner.py, learning from the row's observation (on the last
episode, SuperSuit's ``terminal_observation``: it resets a copy in the step that ends it). Through the adapter
the numbers are those of examples/independent_learner.py on the same seeds, bit for bit
(tests/core/test_outside_libraries.py). The run is logged as one run, as that example's is (docs/platform.md).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a clone without installing
sys.path.insert(0, str(Path(__file__).resolve().parent))  # the learner of independent_learner.py
import supersuit  # noqa: E402
from independent_learner import ValueProportional  # noqa: E402

from mgrao_client import Client  # noqa: E402
from mgrao_core.env import parallel_env  # noqa: E402


def train(system: str, first_seed: int, copies: int, episodes: int) -> list[tuple[int, list[float], list[list[float]]]]:
    """Train fresh children on the engine's seeds ``first_seed`` .. ``first_seed + copies - 1`` through SuperSuit.

    Returns:
        For each copy, its seed, each episode's system utility and its children's final weights.
    """
    env = parallel_env(system, seed=first_seed, episodes=episodes)
    agents = env.possible_agents
    vector = supersuit.concat_vec_envs_v1(supersuit.pettingzoo_env_to_vec_env_v1(env), copies, num_cpus=0,
                                          base_class="gymnasium")
    observations, _ = vector.reset(seed=first_seed)  # copy i: seed first_seed + i
    rows = [ValueProportional(env.params.n_types) for _ in range(copies * len(agents))]  # copy i, child c: row i*n+c
    utilities: list[list[float]] = [[] for _ in range(copies)]
    for _ in range(episodes):
        observations, _, _, _, infos = vector.step(np.stack([learner.act() for learner in rows]))
        for row, learner in enumerate(rows):
            last = infos[row].get("terminal_observation")  # the copy ended and was reset: its last observation
            learner.learn(last if last is not None else {key: value[row] for key, value in observations.items()})
        for i in range(copies):
            utilities[i].append(infos[i * len(agents)]["utility"])
    vector.close()
    return [(first_seed + i, utilities[i],
             [env.allocation(rows[i * len(agents) + c].act()).tolist() for c in range(len(agents))])
            for i in range(copies)]


def main(argv: list[str] | None = None) -> int:
    """Train every seed at once through SuperSuit, log the run, print its job id."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", default=os.environ.get("MGRAO_URL", "http://127.0.0.1:8000"))
    parser.add_argument("--token", default=os.environ.get("MGRAO_API_TOKEN"))
    parser.add_argument("--system", default="single")
    parser.add_argument("--seeds", type=int, default=30, help="seeds 0 .. SEEDS-1, one copy each")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--label", default="value-prop-ss")
    args = parser.parse_args(argv)

    client = Client(args.url, token=args.token)
    run = client.open_run(label=args.label, system=args.system, seeds=args.seeds, episodes=args.episodes,
                          name=f"{args.label}: independent value-proportional children through SuperSuit (examples/)",
                          tags=["example"])
    for seed, utilities, weights in train(args.system, 0, args.seeds, args.episodes):
        run.log(seed, utilities)
        run.log_weights(seed, weights)
    state = run.close()
    print(f"job {run.id}: {state['status']}, {args.seeds} seeds x {args.episodes} episodes of {args.system}")
    print(f"{client.url}/#/jobs/{run.id}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
