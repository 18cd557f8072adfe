"""A learner of your own trained over many worlds at once, logged beside MG-RAO's runs: softmax value-following.

    pip install "mgrao[env]"            # or, in a clone: pip install -e ".[env]"
    mgrao serve &                        # or any running service
    python examples/vector_learner.py [--url http://127.0.0.1:8000] [--token T] [--worlds 256]
                                      [--episodes 200] [--label softmax-value] [--system large] [--step 0.02]

Every world's child learns on its own, numpy only, all worlds in one array: its allocation is a softmax
of one logit per atomic type, and after each episode each logit moves by ``--step`` times the value that
came back for that type less the mean over types. The whole population is stepped together through
:func:`mgrao_core.env.vector_env` (world ``i`` is the engine's seed ``i``), so a step costs one call of
the compiled engine for every world. It is not MG-RAO (no parent groups, no trace): a learner of its
own, in the same worlds, for systems with one resource (an action is one allocation per world). The
script logs each world's episode utilities and final weights through :mod:`mgrao_client` as one run,
then prints the run's job id and where to compare it with a built-in job of the same system, seeds and
episodes (``uniform`` and ``mgrao-max``): docs/platform.md.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a clone without installing
from mgrao_client import Client  # noqa: E402
from mgrao_core.env import vector_env  # noqa: E402


class SoftmaxValue:
    """Every world's child: an allocation ``softmax(logits)``, the logits following the value per type.

    Args:
        n_worlds: worlds trained at once (one child each here; one learner per child and world).
        n_types: atomic types (the length of an action).
        step: how far a logit moves per unit of value above the types' mean.
    """

    def __init__(self, n_worlds: int, n_types: int, step: float = 0.02) -> None:
        self.logits = np.zeros((n_worlds, n_types))
        self.step = step

    def act(self) -> np.ndarray:
        """Every world's allocation, ``(n_worlds, n_types)``."""
        weights = np.exp(self.logits - self.logits.max(axis=1, keepdims=True))
        return weights / weights.sum(axis=1, keepdims=True)

    def learn(self, observation: dict[str, np.ndarray]) -> None:
        """Fold in what came back last episode in every world: the values received, summed per type."""
        worlds, parents, tasks = np.nonzero(observation["received"])
        per_type = np.zeros_like(self.logits)
        np.add.at(per_type, (worlds, observation["task_type"][worlds, parents, tasks]),
                  observation["value"][worlds, parents, tasks])
        self.logits += self.step * (per_type - per_type.mean(axis=1, keepdims=True))


def train(system: str, seeds: list[int], episodes: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Train every world's children together.

    Returns:
        Each world's episode utilities ``(worlds, episodes)`` and its children's final weights ``(worlds,
        children, n_types)``.
    """
    env = vector_env(system, seeds=seeds, episodes=episodes)
    observations, _ = env.reset()
    learners = {agent: SoftmaxValue(len(seeds), env.params.n_types, step) for agent in env.possible_agents}
    utilities = []
    while env.agents:
        observations, _, _, _, infos = env.step({agent: learners[agent].act() for agent in env.agents})
        for agent, observation in observations.items():
            learners[agent].learn(observation)
        utilities.append(infos[env.possible_agents[0]]["utility"])
    weights = np.stack([learners[agent].act() for agent in env.possible_agents], axis=1)
    return np.array(utilities).T, weights


def main(argv: list[str] | None = None) -> int:
    """Train every world at once, log the run, print its job id."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", default=os.environ.get("MGRAO_URL", "http://127.0.0.1:8000"))
    parser.add_argument("--token", default=os.environ.get("MGRAO_API_TOKEN"))
    parser.add_argument("--system", default="large")
    parser.add_argument("--worlds", type=int, default=256, help="worlds of seeds 0 .. WORLDS-1, trained at once")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--step", type=float, default=0.02)
    parser.add_argument("--label", default="softmax-value")
    args = parser.parse_args(argv)

    client = Client(args.url, token=args.token)
    run = client.open_run(label=args.label, system=args.system, seeds=args.worlds, episodes=args.episodes,
                          name=f"{args.label}: softmax value-following, {args.worlds} worlds at once (examples/)",
                          tags=["example"])
    utilities, weights = train(args.system, list(run.seeds), args.episodes, args.step)
    for i, seed in enumerate(run.seeds):
        run.log(seed, utilities[i].tolist())
        run.log_weights(seed, weights[i].tolist())
    state = run.close()
    print(f"job {run.id}: {state['status']}, {args.worlds} seeds x {args.episodes} episodes of {args.system}")
    print(f"{client.url}/#/jobs/{run.id}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
