"""A learner of your own in MG-RAO's world, logged beside MG-RAO's runs: independent value-proportional children.

    pip install "mgrao[env]"            # or, in a clone: pip install -e ".[env]"
    mgrao serve &                        # or any running service
    python examples/independent_learner.py [--url http://127.0.0.1:8000] [--token T] [--seeds 30]
                                           [--episodes 100] [--label value-prop] [--system single]

Each child learns on its own, through the PettingZoo environment :func:`mgrao_core.env.parallel_env`,
from nothing but its observations: an exponential moving average of the value that came back to it per
atomic type per episode, and an allocation proportional to that average, mixed with a little of the
uniform allocation so that every type keeps being tried. It is not MG-RAO (no parent groups, no trace):
a learner of its own, run in the same world (seed ``s`` is the engine's seed ``s``). The script trains
it on ``--seeds`` seeds and logs each seed's episode utilities and final weights through
:mod:`mgrao_client` as one run, then prints the run's job id and where to compare it with a built-in
job of the same system, seeds and episodes (``uniform`` and ``mgrao-max``): docs/platform.md.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a clone without installing
from mgrao_client import Client  # noqa: E402
from mgrao_core.env import parallel_env  # noqa: E402


class ValueProportional:
    """One child: weights proportional to a moving average of the value each type brought back.

    Args:
        n_types: atomic types (the length of an action).
        smoothing: weight of the newest episode in the moving average.
        explore: share of the allocation kept uniform.
    """

    def __init__(self, n_types: int, smoothing: float = 0.2, explore: float = 0.1) -> None:
        self.value = np.zeros(n_types)
        self.smoothing = smoothing
        self.explore = explore

    def act(self) -> np.ndarray:
        """This episode's resource weights (the environment normalises them; zeros mean uniform)."""
        total = self.value.sum()
        if total <= 0:
            return np.zeros_like(self.value)
        return (1 - self.explore) * self.value / total + self.explore / self.value.size

    def learn(self, observation: dict[str, np.ndarray]) -> None:
        """Fold in what came back last episode: the values of the tasks received, summed per type."""
        received = observation["received"] == 1
        per_type = np.bincount(observation["task_type"][received], weights=observation["value"][received],
                               minlength=self.value.size)
        self.value += self.smoothing * (per_type - self.value)


def train(system: str, seed: int, episodes: int) -> tuple[list[float], list[list[float]]]:
    """Train fresh children on the engine's seed ``seed``; each episode's system utility and the final weights."""
    env = parallel_env(system, seed=seed, episodes=episodes)
    observations, _ = env.reset()
    n_types = env.params.n_types
    children = {agent: ValueProportional(n_types) for agent in env.possible_agents}
    utilities = []
    while env.agents:
        actions = {agent: children[agent].act() for agent in env.agents}
        observations, _, _, _, infos = env.step(actions)
        for agent, observation in observations.items():
            children[agent].learn(observation)
        utilities.append(infos[env.possible_agents[0]]["utility"])
    weights = [env.allocation(children[agent].act()).tolist() for agent in env.possible_agents]
    return utilities, weights


def main(argv: list[str] | None = None) -> int:
    """Train on every seed, log the run, print its job id."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", default=os.environ.get("MGRAO_URL", "http://127.0.0.1:8000"))
    parser.add_argument("--token", default=os.environ.get("MGRAO_API_TOKEN"))
    parser.add_argument("--system", default="single")
    parser.add_argument("--seeds", type=int, default=30, help="seeds 0 .. SEEDS-1")
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--label", default="value-prop")
    args = parser.parse_args(argv)

    client = Client(args.url, token=args.token)
    run = client.open_run(label=args.label, system=args.system, seeds=args.seeds, episodes=args.episodes,
                          name=f"{args.label}: independent value-proportional children (examples/)",
                          tags=["example"])
    for seed in run.seeds:
        utilities, weights = train(args.system, seed, args.episodes)
        run.log(seed, utilities)
        run.log_weights(seed, weights)
    state = run.close()
    print(f"job {run.id}: {state['status']}, {args.seeds} seeds x {args.episodes} episodes of {args.system}")
    print(f"{client.url}/#/jobs/{run.id}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
