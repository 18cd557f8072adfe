"""The simulated world as a PettingZoo environment: outside learners act in exactly the engine's world.

:func:`parallel_env` returns a PettingZoo ``ParallelEnv`` (and, for one-child systems,
:func:`single_agent_env` a Gymnasium ``Env``) over the dense reference's environment
(:class:`mgrao_core.reference.SeedEnvironment`): the seed's world and per-episode streams drawn as
the engine draws them (:mod:`mgrao_core.world`), and the paper's steps 1 to 5 computed with
:mod:`mgrao_core.equations` and :mod:`mgrao_core.quality`, parents leaving and rejoining and
choosing children from their estimates included. Only the children's part is the learner's: an
allocation at the start of each episode (the action) and whatever it learns from what comes back
(the observation). docs/platform.md ("A learner of your own in the same world") describes it.

* **Agents**: the children, ``"child_0"`` .. ``"child_{n-1}"``.
* **One step is one episode**; the episodes end by truncation after ``episodes`` steps (never by
  termination).
* **Action**: the child's resource weights over the atomic types, ``Box(0, 1, (n_types,), float64)``.
  The environment sum-normalises them (only proportions matter, so values above 1 are read as
  they are; weights already summing to 1 within 1e-12 are taken unchanged); all zeros means
  uniform. A negative, non-finite or misshapen action is refused.
* **Observation**: what the paper lets a child see, what came back to it last episode, as a
  ``Dict`` of fixed-size ``(n_parents, types_per_composite)`` arrays, one entry per parent and per
  atomic task of the parent's composite task:

  - ``received`` (``MultiBinary``, int8): 1 where the child received that atomic task; the mask of
    the others. Everything is 0 where it is 0 (an absent parent, a task given to another child,
    and every entry at reset);
  - ``task_type`` (``MultiDiscrete(n_types)``, int64): the task's atomic type;
  - ``value`` (``Box(0, 1)``, float64): the absolute value ``atv = taq * ctv`` returned for it;
  - ``position`` (``MultiDiscrete(n_parents * types_per_composite)``, int64): the order of returns,
    0 for the first value that came back to this child in the episode, 1 for the next, and so on
    (composite by composite in the episode's random order of parents, then atomic task by atomic
    task: the order in which MG-RAO learns from them).

* **Reward**: the sum of the absolute values returned to the child in the episode.
* **Infos**: ``{"utility": system utility of the episode, "episode": its index from 0}``, the same
  for every child (empty at reset).
* **Seeds**: ``reset(seed=s)`` gives the world of the engine's seed ``s``, with the same draws
  (common random numbers); ``reset()`` without a seed, the constructor's ``seed`` again.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.errors import ConfigError
from mgrao_core.params import SystemParams, make_params
from mgrao_core.presets import get_preset
from mgrao_core.reference import Episode, SeedEnvironment
from mgrao_core.spec import MAX_SEED_VALUE

try:
    import gymnasium
    from gymnasium import spaces
    from pettingzoo import ParallelEnv
except ImportError as error:  # pragma: no cover - the extra is part of the test install
    raise ImportError(
        "mgrao_core.env needs PettingZoo and Gymnasium: pip install 'mgrao[env]'") from error

__all__ = ["MgraoParallelEnv", "MgraoSingleChildEnv", "parallel_env", "single_agent_env"]

NORMALISED = 1e-12
"""An action whose weights sum to 1 within this is taken as it is: normalising it again would move its
weights by a rounding, enough to turn a parent's exactly tied choice of child the other way."""
DRAW_BLOCK = 256
"""Episodes drawn from the seed's streams at a time (the numbers do not depend on it)."""


def _seed(value: Any, field: str = "seed") -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 0 <= value <= MAX_SEED_VALUE:
        raise ConfigError(field, f"must be a whole number in [0, {MAX_SEED_VALUE}] (got {value!r})")
    return int(value)


def system_params(system: str, params: dict[str, Any]) -> SystemParams:
    """A preset's parameters with ``params`` on top, validated as a job's (:func:`mgrao_core.make_params`)."""
    return make_params(params, base=get_preset(system).params)


class MgraoParallelEnv(ParallelEnv):
    """The world of a system as a PettingZoo ``ParallelEnv`` (module docstring: agents, spaces, seeds).

    Build it with :func:`parallel_env`.

    Attributes:
        system: the preset it starts from.
        params: the full parameter set (preset plus overrides).
        seed: the seed ``reset()`` without one uses.
        episodes: steps before truncation.
    """

    metadata = {"name": "mgrao_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, system: str = "single", seed: int = 0, episodes: int = 100, **params: Any) -> None:
        self.system = system
        self.params = system_params(system, params)
        self.seed = _seed(seed)
        if isinstance(episodes, bool) or not isinstance(episodes, int | np.integer) or episodes < 1:
            raise ConfigError("episodes", f"must be a whole number of at least 1 (got {episodes!r})")
        self.episodes = int(episodes)
        self.render_mode = None
        p = self.params
        if p.n_resources > 1:  # an action is one allocation; several resources would need one per resource
            raise ConfigError("n_resources", f"the PettingZoo environment supports one resource (got {p.n_resources}): "
                                             "its action is one allocation over the atomic types (docs/platform.md)")
        self.possible_agents = [f"child_{c}" for c in range(p.n_children)]
        self.agents: list[str] = []
        self._index = {agent: c for c, agent in enumerate(self.possible_agents)}
        self._shape = (p.n_parents, p.types_per_composite)
        self._observation_spaces = {agent: self._observation_space() for agent in self.possible_agents}
        self._action_spaces = {agent: spaces.Box(0.0, 1.0, (p.n_types,), np.float64)
                               for agent in self.possible_agents}
        self._environment: SeedEnvironment | None = None
        self._uniform = np.full(p.n_types, 1.0 / p.n_types)

    def _observation_space(self) -> spaces.Dict:
        n_parents, k = self._shape
        return spaces.Dict({
            "received": spaces.MultiBinary([n_parents, k]),
            "task_type": spaces.MultiDiscrete(np.full(self._shape, self.params.n_types, dtype=np.int64)),
            "value": spaces.Box(0.0, 1.0, self._shape, np.float64),
            "position": spaces.MultiDiscrete(np.full(self._shape, n_parents * k, dtype=np.int64)),
        })

    def observation_space(self, agent: str) -> spaces.Dict:
        """The child's observation space (the same object on every call)."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        """The child's action space (the same object on every call)."""
        return self._action_spaces[agent]

    @property
    def world_seed(self) -> int | None:
        """The engine's seed whose world the current episodes run in (None before the first reset)."""
        return None if self._environment is None else self._environment.seed

    @property
    def episode(self) -> int:
        """Episodes played since the last reset."""
        return 0 if self._environment is None else self._environment.episode

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Start the world of the engine's seed ``seed`` (the constructor's when None) at episode 0.

        Returns:
            Each child's observation (nothing received yet: every entry 0) and an empty info.
        """
        world_seed = self.seed if seed is None else _seed(seed)
        self._environment = SeedEnvironment(self.params, world_seed, block=min(self.episodes, DRAW_BLOCK))
        self.agents = list(self.possible_agents)
        empty = {"received": np.zeros(self._shape, np.int8), "task_type": np.zeros(self._shape, np.int64),
                 "value": np.zeros(self._shape), "position": np.zeros(self._shape, np.int64)}
        return ({agent: {key: value.copy() for key, value in empty.items()} for agent in self.agents},
                {agent: {} for agent in self.agents})

    def allocation(self, action: Any, agent: str = "") -> np.ndarray:
        """The weights an action stands for: sum-normalised, all zeros meaning uniform.

        Weights that already sum to 1 (within :data:`NORMALISED`) are taken as they are.

        Raises:
            ValueError: not ``n_types`` finite values at least 0 (the message names the agent).
        """
        weights = np.asarray(action, dtype=np.float64)
        n_types = self.params.n_types
        if weights.shape != (n_types,):
            raise ValueError(f"{agent}: an action is {n_types} weights, one per atomic type (got shape "
                             f"{weights.shape})")
        if not np.all(np.isfinite(weights)) or np.any(weights < 0):
            raise ValueError(f"{agent}: weights must be finite and at least 0 (got {weights.tolist()})")
        if abs(weights.sum() - 1.0) <= NORMALISED:
            return weights  # normalised already: dividing again would only add rounding
        return eq.sumnorm(weights)

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """One episode, each child holding the allocation its action gives.

        Returns:
            observations, rewards, terminations, truncations and infos, keyed by child.

        Raises:
            RuntimeError: before :meth:`reset`, or after the last episode.
            ValueError: a child without an action, or an action that is not one (:meth:`allocation`).
        """
        if self._environment is None or not self.agents:
            raise RuntimeError("call reset() first: no episode is under way")
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise ValueError(f"no action for {', '.join(missing)}")
        weights = [self.allocation(actions[agent], agent) for agent in self.agents]
        episode = self._environment.step(weights)
        observations, rewards = self._observe(episode)
        done = self._environment.episode >= self.episodes
        info = {"utility": float(episode.utility), "episode": self._environment.episode - 1}
        agents = self.agents
        if done:
            self.agents = []
        return (observations, rewards, dict.fromkeys(agents, False), dict.fromkeys(agents, done),
                {agent: dict(info) for agent in agents})

    def _observe(self, episode: Episode) -> tuple[dict, dict]:
        """Each child's observation and reward from what came back to it (module docstring)."""
        n_parents, k = self._shape
        child_of = episode.child_of.ravel()
        returned = (np.asarray(episode.order, dtype=np.int64)[:, None] * k + np.arange(k)).ravel()
        types = episode.task_types.ravel()  # this episode's (events and unpredictable parents change them)
        values = episode.values.ravel()
        observations, rewards = {}, {}
        for agent in self.agents:
            c = self._index[agent]
            mine = returned[child_of[returned] == c]  # flat entries, in the order they came back
            received = np.zeros(n_parents * k, np.int8)
            received[mine] = 1
            task_type = np.zeros(n_parents * k, np.int64)
            task_type[mine] = types[mine]
            value = np.zeros(n_parents * k)
            value[mine] = values[mine]
            position = np.zeros(n_parents * k, np.int64)
            position[mine] = np.arange(mine.size)
            observations[agent] = {"received": received.reshape(self._shape),
                                   "task_type": task_type.reshape(self._shape),
                                   "value": value.reshape(self._shape),
                                   "position": position.reshape(self._shape)}
            rewards[agent] = float(values[mine].sum())
        return observations, rewards

    def render(self) -> None:
        """Nothing to render (the dashboard shows runs)."""

    def close(self) -> None:
        """Nothing to release."""


def parallel_env(system: str = "single", seed: int = 0, episodes: int = 100, **params: Any) -> MgraoParallelEnv:
    """The world the engine simulates for ``system`` with ``params`` on top, as a PettingZoo ``ParallelEnv``.

    Args:
        system: a preset: single, multi, volatile or large.
        seed: the engine's seed whose world ``reset()`` without a seed gives.
        episodes: steps (episodes) before truncation.
        **params: parameter overrides, as ``--set name=value`` (docs/model.md).

    Raises:
        ConfigError: an unknown system or parameter, or a value outside its limits (naming it).
    """
    return MgraoParallelEnv(system, seed, episodes, **params)


class MgraoSingleChildEnv(gymnasium.Env):
    """A one-child system as a Gymnasium ``Env``: the :class:`MgraoParallelEnv` of its only child.

    The spaces, reward and info are that child's; ``reset(seed=s)`` also gives the world of the
    engine's seed ``s`` (and seeds ``np_random``, which the environment itself never draws from).
    Build it with :func:`single_agent_env`.
    """

    metadata = {"render_modes": []}

    def __init__(self, system: str = "single", seed: int = 0, episodes: int = 100, **params: Any) -> None:
        self.parallel = MgraoParallelEnv(system, seed, episodes, **params)
        if self.parallel.params.n_children != 1:
            raise ConfigError("n_children", f"a single-agent environment needs one child (got "
                                            f"{self.parallel.params.n_children}): use parallel_env")
        self.agent = self.parallel.possible_agents[0]
        self.observation_space = self.parallel.observation_space(self.agent)
        self.action_space = self.parallel.action_space(self.agent)
        self.render_mode = None

    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Start the world of the engine's seed ``seed`` (the constructor's when None)."""
        super().reset(seed=seed)
        observations, infos = self.parallel.reset(seed=seed, options=options)
        return observations[self.agent], infos[self.agent]

    def step(self, action: Any) -> tuple[dict, float, bool, bool, dict]:
        """One episode with the child's allocation ``action`` (see :meth:`MgraoParallelEnv.allocation`)."""
        observations, rewards, terminations, truncations, infos = self.parallel.step({self.agent: action})
        a = self.agent
        return observations[a], rewards[a], terminations[a], truncations[a], infos[a]


def single_agent_env(system: str = "single", seed: int = 0, episodes: int = 100,
                     **params: Any) -> MgraoSingleChildEnv:
    """A one-child system's world as a Gymnasium ``Env`` (arguments as :func:`parallel_env`).

    Raises:
        ConfigError: as :func:`parallel_env`, or the system has more than one child.
    """
    return MgraoSingleChildEnv(system, seed, episodes, **params)
