"""The simulated world as a PettingZoo environment: outside learners act in exactly the engine's world.

:func:`parallel_env` returns a PettingZoo ``ParallelEnv`` (and, for one-child systems,
:func:`single_agent_env` a Gymnasium ``Env``), and :func:`vector_env` one that steps many worlds at
once, with a leading world axis on everything. All three run on the compiled engine
(:class:`mgrao_core.stepper.SteppedWorlds`: the kernel's own episode, the engine's world and draws of
each seed), parents leaving and rejoining and choosing children from their estimates included; the
dense reference (:class:`mgrao_core.reference.SeedEnvironment`) checks them in the tests. Only the
children's part is the learner's: an allocation at the start of each episode (the action) and
whatever it learns from what comes back (the observation). docs/platform.md ("A learner of your own
in the same world") describes them.

* **Agents**: the children, ``"child_0"`` .. ``"child_{n-1}"``.
* **One step is one episode**; the episodes end by truncation after ``episodes`` steps (never by
  termination).
* **Action**: the child's resource weights over the atomic types, ``Box(0, 1, (n_types,), float64)``
  (a :class:`WeightsSpace`); with several resources (``n_resources`` R > 1), one allocation per
  resource, ``(R, n_types)``.
  The environment sum-normalises them (only proportions matter, so values above 1 are read as
  they are; weights already summing to 1 within 1e-12 are taken unchanged; weights whose sum
  overflows are divided by their largest first); all zeros means uniform. A negative, non-finite,
  misshapen or non-numeric action (text, complex numbers, booleans), or one for an agent that is not one,
  is refused naming the child, before anything is stepped.
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
    task: the order in which MG-RAO learns from them);

  and the child's own: ``allocation`` (``Box(0, 1, (n_types,))``) the weights it held in that episode (0
  at reset), ``resources`` (``Box(0, inf, (n_types,))``) its resource per unit of weight of each type
  (its amount over its capability; with several resources both are ``(R, n_types)``, each resource
  relative to the type's need of it), ``episode`` (``MultiDiscrete(episodes + 1)``, shape ``(1,)``) the
  episodes played. With ``flatten=True`` the observation is one ``Box`` of :func:`flat_length` float64
  numbers, these entries flattened in the order of :data:`OBSERVATION_KEYS`.
* **Reward**: the sum of the absolute values returned to the child in the episode (added in the
  order they came back); with ``reward="team"``, the system utility, for every child.
* **State** (``state()``, ``state_space``), for centralised training: every child's flat observation in
  agent order, then each parent's presence (1 or 0) in the last episode.
* **Infos**: ``{"utility": system utility of the episode, "episode": its index from 0}``, the same
  for every child (empty at reset).
* **Seeds**: ``reset(seed=s)`` gives the world of the engine's seed ``s``, with the same draws
  (common random numbers); ``reset()`` without a seed draws a fresh world from the environment's
  generator, seeded by the last ``reset(seed=...)`` (Gymnasium's convention); the first ``reset()``
  without any gives the constructor's ``seed``.
* **Reset options**: none. The vector environment refuses any option naming it (Gymnasium's autoreset sends
  ``reset_mask`` to reset some worlds only, and a reset here starts every world); the one-world environments
  refuse ``reset_mask`` too and ignore other keys, as PettingZoo's API test requires (it resets with
  ``options={"options": 1}``). Nothing is reset by a refused call.
* **Many worlds** (:func:`vector_env`): the same, world ``i`` being the engine's seed ``seeds[i]``, with
  a leading axis of length ``n_worlds`` on every action ``(n_worlds, n_types)``, observation entry,
  reward, termination, truncation and info entry, and on the spaces. ``reset(seed=s)`` with a whole
  number gives the worlds of seeds ``s, s + 1, ...`` (Gymnasium's vector convention), with a list, those
  seeds; ``reset()``, the constructor's. Every world ends after ``episodes`` steps, together.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.errors import ConfigError
from mgrao_core.params import SystemParams, make_params
from mgrao_core.presets import get_preset
from mgrao_core.spec import MAX_SEED_VALUE
from mgrao_core.stepper import SteppedWorlds

try:
    import gymnasium
    from gymnasium import spaces
    from pettingzoo import ParallelEnv
except ImportError as error:  # pragma: no cover - the extra is part of the test install
    raise ImportError(
        "mgrao_core.env needs PettingZoo and Gymnasium: pip install 'mgrao[env]'") from error

__all__ = ["MgraoParallelEnv", "MgraoSingleChildEnv", "MgraoVectorEnv", "parallel_env", "single_agent_env",
           "vector_env"]

NORMALISED = 1e-12
"""An action whose weights sum to 1 within this is taken as it is: normalising it again would move its
weights by a rounding, enough to turn a parent's exactly tied choice of child the other way."""
DRAW_BLOCK = 256
"""Episodes drawn from the seeds' streams at a time (the numbers do not depend on it)..."""
DRAWN_WORLD_EPISODES = 32_768
"""... and at most this many world-episodes at once (about 90 MB of draws on large, 2.8 kB each)."""
RETURNED_KEYS = ("received", "task_type", "value", "position")
"""The observation's entries of what came back to the child, one per parent and atomic task."""
OBSERVATION_KEYS = (*RETURNED_KEYS, "allocation", "resources", "episode")
"""Every entry of an observation, in the order of its flat form (``flatten=True``)."""
REWARDS = ("child", "team")
_LARGEST = float(np.finfo(np.float64).max)


def _seed(value: Any, field: str = "seed") -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 0 <= value <= MAX_SEED_VALUE:
        raise ConfigError(field, f"must be a whole number in [0, {MAX_SEED_VALUE}] (got {value!r})")
    return int(value)


def _seeds(value: Any, n_worlds: int | None, field: str = "seeds") -> tuple[int, ...]:
    """A list of distinct seeds (``n_worlds`` of them when given), or a whole number ``s`` for ``s, s + 1, ...``."""
    if isinstance(value, int | np.integer) and not isinstance(value, bool):
        if n_worlds is None:
            raise ConfigError(field, f"must be a list of seeds (got {value!r})")
        first = _seed(value, field)
        if first + n_worlds - 1 > MAX_SEED_VALUE:
            raise ConfigError(field, f"seeds {first} to {first + n_worlds - 1} pass {MAX_SEED_VALUE}")
        return tuple(range(first, first + n_worlds))
    if isinstance(value, str) or not isinstance(value, Sequence | range | np.ndarray):
        raise ConfigError(field, f"must be a list of seeds or a whole number (got {value!r})")
    seeds = tuple(_seed(s, f"{field}[{i}]") for i, s in enumerate(value))
    if not seeds:
        raise ConfigError(field, "must name at least one seed")
    if len(set(seeds)) != len(seeds):
        raise ConfigError(field, "must not repeat a seed")
    if n_worlds is not None and len(seeds) != n_worlds:
        raise ConfigError(field, f"must be {n_worlds} seeds, one per world (got {len(seeds)})")
    return seeds


def _episodes(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ConfigError("episodes", f"must be a whole number of at least 1 (got {value!r})")
    return int(value)


def system_params(system: str, params: dict[str, Any]) -> SystemParams:
    """A preset's parameters with ``params`` on top, validated as a job's (:func:`mgrao_core.make_params`).

    Raises:
        ConfigError: a ``learning_cost``: the children here are the caller's learner, whose learning the
            environment cannot price (it would have to know what the learner keeps).
    """
    validated = make_params(params, base=get_preset(system).params)
    if validated.learning_cost:
        raise ConfigError("learning_cost", "must be 0 in the environments: their children are your learner, whose "
                                           "learning they cannot price")
    return validated


def allocations(action: Any, agent: str, n_types: int) -> np.ndarray:
    """The weights an action stands for, as the environments read it (module docstring: "Action").

    ``action`` is ``(..., n_types)``: one allocation or one per world. Each is sum-normalised (all zeros
    meaning uniform) unless it sums to 1 within :data:`NORMALISED` already; one whose sum overflows is
    divided by its largest weight first.

    Raises:
        ValueError: not finite real numbers at least 0 of that shape (the message names the agent): complex
            numbers and booleans (even one among numbers, which numpy would read as 1.0) are refused as the
            weights they are not, as text is.
    """
    try:
        given = np.asarray(action)
        odd = _not_real(given, action)
        weights = given.astype(np.float64, copy=False) if odd is None and given.dtype.kind in "iufO" else None
    except (TypeError, ValueError):
        odd, weights = None, None
    if odd is not None:
        raise ValueError(f"{agent}: an action is {n_types} real numbers, one weight per atomic type (got {odd}: "
                         f"{str(action)[:60]})")
    if weights is None:
        raise ValueError(f"{agent}: an action is {n_types} numbers, one weight per atomic type "
                         f"(got {str(action)[:60]!r})")
    if weights.ndim == 0 or weights.shape[-1] == 0:
        raise ValueError(f"{agent}: an action is {n_types} numbers, one weight per atomic type (got "
                         f"{str(action)[:60] if weights.ndim == 0 else 'none'})")
    if weights.size == weights.shape[-1]:  # one allocation: tested on Python floats, a fraction of numpy's cost
        listed = weights.ravel().tolist()
        if min(listed) >= 0.0 and max(listed) * len(listed) < _LARGEST:  # a NaN may pass these; its sum will not
            one = float(weights.sum())
            if abs(one - 1.0) <= NORMALISED:
                return weights  # normalised already: dividing again would only add rounding
            if 0.0 < one < np.inf:
                return weights / one  # eq.sumnorm's division, the same numbers
    highest = float(weights.max()) if weights.size else 0.0  # a Python float: its product overflows to inf quietly
    if weights.size and not (weights.min() >= 0.0 and highest < np.inf):  # NaN fails both comparisons
        raise ValueError(f"{agent}: weights must be finite and at least 0 (got {str(weights.tolist())[:200]})")
    if highest * weights.shape[-1] < _LARGEST:
        total = weights.sum(axis=-1, keepdims=True)
    else:
        with np.errstate(over="ignore"):
            total = weights.sum(axis=-1, keepdims=True)
    if (np.abs(total - 1.0) <= NORMALISED).all():
        return weights
    if not np.isfinite(total).all():  # sums past the largest float: the same proportions, scaled down first
        largest = weights.max(axis=-1, keepdims=True)
        weights = weights / np.where(np.isfinite(total), 1.0, largest)
        total = weights.sum(axis=-1, keepdims=True)
    return np.where(np.abs(total - 1.0) <= NORMALISED, weights, eq.sumnorm(weights))


def _not_real(given: np.ndarray, action: Any) -> str | None:
    """What an action holds that a weight is not (``"complex numbers"``, ``"booleans"``), or None.

    ``given`` is ``np.asarray(action)``; a list mixing booleans with numbers is read by numpy as numbers, so a
    list's items are looked at too.
    """
    kind = given.dtype.kind
    if kind == "c":
        return "complex numbers"
    if kind == "b":
        return "booleans"
    if kind == "O":
        items = given.ravel().tolist()
        if any(isinstance(x, complex | np.complexfloating) for x in items):
            return "complex numbers"
        return "booleans" if any(isinstance(x, bool | np.bool_) for x in items) else None
    if kind in "iuf" and isinstance(action, list | tuple) and _holds_a_boolean(action):
        return "booleans"
    return None


_PLAIN = frozenset({float, int, np.float64})
"""The types of a list's items that are numbers and no booleans, for a quick look before a closer one."""


def _holds_a_boolean(items: list | tuple) -> bool:
    if _PLAIN.issuperset(map(type, items)):
        return False
    for item in items:
        if isinstance(item, bool | np.bool_) or (isinstance(item, np.ndarray) and item.dtype.kind == "b"):
            return True
        if isinstance(item, list | tuple) and _holds_a_boolean(item):
            return True
    return False


PARTIAL_RESET = "reset_mask"
"""Gymnasium's vector option to reset some worlds only; no environment here can (a reset starts every world)."""


def _options(options: Any, *, vector: bool) -> None:
    """Refuse reset options the environment would not honour, naming them (module docstring: "Reset options").

    The vector environment takes none: every option is refused (Gymnasium's autoreset sends ``reset_mask`` to
    reset some worlds only). The one-world environments refuse ``reset_mask`` and ignore other keys, as
    PettingZoo's API test requires of them (it resets with ``options={"options": 1}``).
    """
    if options is None:
        return
    if not isinstance(options, dict):
        raise ConfigError("options", f"must be a dict of options or None (got {type(options).__name__})")
    refused = sorted(map(str, options)) if vector else [PARTIAL_RESET] if PARTIAL_RESET in options else []
    if refused:
        raise ConfigError("options", f"unknown option{'s' if len(refused) > 1 else ''} {', '.join(refused)}: "
                                     f"this environment takes none (a reset starts every world)")


def _reward(value: Any) -> str:
    if value not in REWARDS:
        raise ConfigError("reward", f"must be one of {', '.join(REWARDS)} (got {value!r})")
    return value


def flat_length(params: SystemParams) -> int:
    """The length of a flat observation: ``4 * n_parents * types_per_composite + 2 * n_resources * n_types + 1``."""
    return 4 * params.n_parents * params.types_per_composite + 2 * params.n_resources * params.n_types + 1


class WeightsSpace(spaces.Box):
    """The action space: weights in [0, 1] of a given shape, a gymnasium ``Box``.

    :meth:`sample` draws the numbers ``Box.sample`` draws (one uniform draw per weight from
    ``np_random``, in order), in one call: gymnasium's general sampler sorts every bound into four kinds
    first, which cost several times a step of the environment (benchmarks/bench_vector_env.py).
    """

    def __init__(self, shape: tuple[int, ...]) -> None:
        super().__init__(0.0, 1.0, shape, np.float64)

    def sample(self, mask: None = None, probability: None = None) -> np.ndarray:
        """Uniform weights, as ``Box.sample`` (which refuses a mask or probability; so does this)."""
        if mask is not None or probability is not None:
            return super().sample(mask, probability)
        return self.np_random.uniform(0.0, 1.0, self.shape)


def action_shape(params: SystemParams) -> tuple[int, ...]:
    """One child's action (and allocation): ``(n_types,)``, with several resources ``(n_resources, n_types)``."""
    return (params.n_types,) if params.n_resources == 1 else (params.n_resources, params.n_types)


def _entry_bounds(params: SystemParams, episodes: int) -> dict[str, tuple[float, float, int]]:
    """Each entry's lowest and highest value and its size (one world)."""
    grid = params.n_parents * params.types_per_composite
    n_types, own = params.n_types, params.n_resources * params.n_types
    return {"received": (0, 1, grid), "task_type": (0, n_types - 1, grid), "value": (0.0, 1.0, grid),
            "position": (0, grid - 1, grid), "allocation": (0.0, 1.0, own), "resources": (0.0, np.inf, own),
            "episode": (0, episodes, 1)}


def observation_space(params: SystemParams, episodes: int, batch: tuple[int, ...] = (),
                      flatten: bool = False) -> spaces.Space:
    """A child's observation space, with ``batch`` as leading axes (module docstring: "Observation").

    A ``Dict`` of :data:`OBSERVATION_KEYS`, or with ``flatten`` one ``Box`` of :func:`flat_length` numbers
    (float64): the entries flattened in that order.
    """
    grid = (*batch, params.n_parents, params.types_per_composite)
    types = (*batch, *action_shape(params))
    if flatten:
        bounds = _entry_bounds(params, episodes).values()
        low = np.concatenate([np.full(size, low, np.float64) for low, _, size in bounds])
        high = np.concatenate([np.full(size, high, np.float64) for _, high, size in bounds])
        shape = (*batch, low.size)
        return spaces.Box(np.broadcast_to(low, shape), np.broadcast_to(high, shape), shape, np.float64)
    return spaces.Dict({
        "received": spaces.MultiBinary(list(grid)),
        "task_type": spaces.MultiDiscrete(np.full(grid, params.n_types, dtype=np.int64)),
        "value": spaces.Box(0.0, 1.0, grid, np.float64),
        "position": spaces.MultiDiscrete(np.full(grid, grid[-2] * grid[-1], dtype=np.int64)),
        "allocation": spaces.Box(0.0, 1.0, types, np.float64),
        "resources": spaces.Box(0.0, np.inf, types, np.float64),
        "episode": spaces.MultiDiscrete(np.full((*batch, 1), episodes + 1, dtype=np.int64)),
    })


def state_space(params: SystemParams, episodes: int, batch: tuple[int, ...] = ()) -> spaces.Box:
    """The state's space: every child's flat observation in agent order, then each parent's presence (0 or 1)."""
    child = observation_space(params, episodes, (), flatten=True)
    low = np.concatenate([np.tile(child.low, params.n_children), np.zeros(params.n_parents)])
    high = np.concatenate([np.tile(child.high, params.n_children), np.ones(params.n_parents)])
    shape = (*batch, low.size)
    return spaces.Box(np.broadcast_to(low, shape), np.broadcast_to(high, shape), shape, np.float64)


class MgraoVectorEnv(ParallelEnv):
    """Many worlds of a system, stepped together on the compiled engine (module docstring: "Many worlds").

    Build it with :func:`vector_env`.

    Attributes:
        system: the preset it starts from.
        params: the full parameter set (preset plus overrides).
        seeds: the engine's seeds of the worlds ``reset()`` without a seed gives.
        n_worlds: how many worlds step at once.
        episodes: steps before truncation.
    """

    metadata = {"name": "mgrao_vector_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, system: str = "single", seeds: Any = range(64), episodes: int = 100, *, reward: str = "child",
                 flatten: bool = False, **params: Any) -> None:
        self.system = system
        self.params = p = system_params(system, params)
        self.seeds = _seeds(seeds, None)
        self.n_worlds = len(self.seeds)
        self.episodes = _episodes(episodes)
        self.reward = _reward(reward)
        self.flatten = bool(flatten)
        self.render_mode = None
        self.possible_agents = [f"child_{c}" for c in range(p.n_children)]
        self.agents: list[str] = []
        self._index = {agent: c for c, agent in enumerate(self.possible_agents)}
        self._world_index: dict[int, dict[str, tuple[int, int]]] = {}  # one world's entries (_observations)
        self._observation_spaces = dict.fromkeys(
            self.possible_agents, observation_space(p, self.episodes, (self.n_worlds,), self.flatten))
        self._action_spaces = {agent: WeightsSpace((self.n_worlds, *action_shape(p)))
                               for agent in self.possible_agents}
        self.state_space = state_space(p, self.episodes, (self.n_worlds,))
        self._worlds: SteppedWorlds | None = None
        self._last: dict[str, np.ndarray] = {}

    def observation_space(self, agent: str) -> spaces.Space:
        """The child's observation space, a leading world axis on every entry (the same object on every call)."""
        return self._observation_spaces[agent]

    def state(self) -> np.ndarray:
        """The state for centralised training, ``(n_worlds, len)`` (:attr:`state_space`).

        Every child's flat observation in agent order, then each parent's presence (1 present, 0 absent) in
        the last episode.
        """
        if self._worlds is None:
            raise RuntimeError("call reset() first: there is no state before it")
        flat = self._flat(self._last)  # (children, worlds, flat_length)
        children = flat.transpose(1, 0, 2).reshape(self.n_worlds, -1)
        return np.concatenate([children, self._worlds.present.astype(np.float64)], axis=1)

    def _flat(self, entries: dict[str, np.ndarray]) -> np.ndarray:
        n_children = len(self.possible_agents)
        return np.concatenate([entries[key].reshape(n_children, self.n_worlds, -1).astype(np.float64)
                               for key in OBSERVATION_KEYS], axis=2)

    def _observations(self, entries: dict[str, np.ndarray], agents: list[str],
                      world: int | None = None) -> dict[str, Any]:
        """Each agent's observation from the entries ``(children, worlds, ...)`` (flat with ``flatten``).

        With ``world``, that world's alone (no world axis).
        """
        self._last = entries
        if world is None:
            index = self._index
        elif (index := self._world_index.get(world)) is None:
            index = self._world_index[world] = {agent: (c, world) for agent, c in self._index.items()}
        if self.flatten:
            flat = self._flat(entries)
            return {agent: flat[index[agent]] for agent in agents}
        return {agent: {key: entries[key][index[agent]] for key in OBSERVATION_KEYS} for agent in agents}

    def _entries(self, returned: dict[str, np.ndarray], weights: np.ndarray) -> dict[str, np.ndarray]:
        """Every entry ``(children, worlds, ...)`` of the observations.

        What came back (``returned``), the allocations ``weights (worlds, children, ...)`` it came back for,
        each child's resources and the episodes played.
        """
        n_children = len(self.possible_agents)
        return returned | {
            "allocation": weights.swapaxes(0, 1).copy(),
            "resources": self._resources.copy(),
            "episode": np.full((n_children, self.n_worlds, 1), self._worlds.episode, np.int64)}

    def action_space(self, agent: str) -> spaces.Box:
        """The child's action space, ``(n_worlds, n_types)`` or ``(n_worlds, R, n_types)`` (the same object)."""
        return self._action_spaces[agent]

    @property
    def world_seeds(self) -> tuple[int, ...] | None:
        """The engine's seeds of the worlds under way (None before the first reset)."""
        return None if self._worlds is None else self._worlds.seeds

    @property
    def episode(self) -> int:
        """Episodes played since the last reset."""
        return 0 if self._worlds is None else self._worlds.episode

    def reset(self, seed: Any = None, options: dict | None = None) -> tuple[dict, dict]:
        """Start the worlds of ``seed`` (a list, or ``s`` for ``s, s + 1, ...``; the constructor's when None).

        Returns:
            Each child's observation (nothing received yet: every entry 0) and an empty info.

        Raises:
            ConfigError: bad seeds, or ``options`` other than None or ``{}`` (the environment takes none: a reset
                starts every world, so Gymnasium's ``reset_mask`` is refused, naming it); nothing is reset.
        """
        _options(options, vector=True)
        seeds = self.seeds if seed is None else _seeds(seed, self.n_worlds, "seed")
        block = min(self.episodes, DRAW_BLOCK, max(1, DRAWN_WORLD_EPISODES // self.n_worlds))
        self._worlds = SteppedWorlds(self.params, seeds, block=block)
        self._resources = np.ascontiguousarray(np.moveaxis(self._worlds.resources, 1, 0))  # fixed for the worlds
        self.agents = list(self.possible_agents)
        p = self.params
        grid = (len(self.agents), self.n_worlds, p.n_parents, p.types_per_composite)
        nothing = {"received": np.zeros(grid, np.int8), "task_type": np.zeros(grid, np.int64),
                   "value": np.zeros(grid), "position": np.zeros(grid, np.int64)}
        entries = self._entries(nothing, np.zeros((self.n_worlds, len(self.agents), *action_shape(p))))
        return self._observations(entries, self.agents), {agent: {} for agent in self.agents}

    def allocation(self, action: Any, agent: str = "") -> np.ndarray:
        """The weights an action ``(n_worlds, n_types)`` (``(n_worlds, R, n_types)``) stands for (:func:`allocations`).

        Raises:
            ValueError: not finite values at least 0 of that shape (the message names the agent).
        """
        shape = self._action_spaces[self.possible_agents[0]].shape
        weights = allocations(action, agent, self.params.n_types)
        if weights.shape != shape:
            raise ValueError(f"{agent}: an action is {shape[-1]} weights per world, one per atomic type, shape "
                             f"{shape} (got shape {weights.shape})")
        return weights

    def _allocations(self, actions: Any, read: Callable[[Any, str], np.ndarray] | None = None) -> np.ndarray:
        """Every child's weights ``(n_worlds, children, ...)``, or ValueError before anything is stepped.

        Each action is read by ``read`` (:meth:`allocation` when None).
        """
        if self._worlds is None or not self.agents:
            raise RuntimeError("call reset() first: no episode is under way")
        if not isinstance(actions, dict):
            raise ValueError(f"actions must be a dict of the agents' actions (got {type(actions).__name__})")
        if actions.keys() != self._index.keys():  # every agent acts while any does
            self._refuse_agents(actions)
        read = read or self.allocation
        weights = np.empty((self.n_worlds, len(self.agents), *action_shape(self.params)))
        for c, agent in enumerate(self.agents):
            weights[:, c] = read(actions[agent], agent)
        return weights

    def _refuse_agents(self, actions: dict[str, Any]) -> None:
        """ValueError naming an agent of ``actions`` that is none, or an agent without an action."""
        unknown = [str(agent) for agent in actions if agent not in self._index]
        if unknown:
            raise ValueError(f"{', '.join(unknown)}: not an agent of this environment (agents: "
                             f"{self.possible_agents[0]} to {self.possible_agents[-1]})")
        missing = [agent for agent in self.agents if agent not in actions]
        if missing:
            raise ValueError(f"no action for {', '.join(missing)}")

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """One episode of every world, each child holding the allocation its action gives in each world.

        Returns:
            observations, rewards, terminations, truncations and infos, keyed by child, each value with a
            leading world axis.

        Raises:
            RuntimeError: before :meth:`reset`, or after the last episode.
            ValueError: a child without an action, an agent that is none, or an action that is not one
                (:meth:`allocation`); nothing is stepped.
        """
        return self._advance(self._allocations(actions))

    def _play(self, weights: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray, list[str]]:
        """One episode of every world with every child's weights read (:meth:`_allocations`).

        Returns:
            The observations' entries ``(children, worlds, ...)`` (kept for :meth:`state`), the rewards
            ``(children, worlds)``, the system utility ``(worlds,)`` and the agents that acted (:attr:`agents`
            is empty after the last episode).
        """
        outcome = self._worlds.step(weights)
        returned, rewards = self._worlds.observe(outcome)
        agents = self.agents
        if self._worlds.episode >= self.episodes:
            self.agents = []
        utility = outcome.utility.copy()
        if self.reward == "team":
            rewards = np.broadcast_to(utility, rewards.shape)
        self._last = self._entries(returned, weights)
        return self._last, rewards, utility, agents

    def _advance(self, weights: np.ndarray) -> tuple[dict, dict, dict, dict, dict]:
        """:meth:`step` with every child's weights read (:meth:`_allocations`)."""
        entries, rewards, utility, agents = self._play(weights)
        done, episode = not self.agents, np.full(self.n_worlds, self._worlds.episode - 1)
        return (self._observations(entries, agents),
                {agent: rewards[c].copy() for c, agent in enumerate(agents)},
                {agent: np.zeros(self.n_worlds, np.bool_) for agent in agents},
                {agent: np.full(self.n_worlds, done) for agent in agents},
                {agent: {"utility": utility.copy(), "episode": episode.copy()} for agent in agents})

    def render(self) -> None:
        """Nothing to render (the dashboard shows runs)."""

    def close(self) -> None:
        """Nothing to release."""


def vector_env(system: str = "single", seeds: Any = range(64), episodes: int = 100, *, reward: str = "child",
               flatten: bool = False, **params: Any) -> MgraoVectorEnv:
    """Many worlds of ``system`` with ``params`` on top, stepped together, as a batched PettingZoo ``ParallelEnv``.

    Args:
        system: a preset (``GET /api/systems`` lists them).
        seeds: the engine's seed of each world (world ``i`` is seed ``seeds[i]``, with its draws).
        episodes: steps (episodes) before every world is truncated.
        reward: ``"child"`` (what came back to the child) or ``"team"`` (the system utility, for every child).
        flatten: observations as one array of :func:`flat_length` numbers per world instead of a ``Dict``.
        **params: parameter overrides, as ``--set name=value`` (docs/model.md).

    Raises:
        ConfigError: an unknown system or parameter, a value outside its limits, bad seeds or reward (naming it).
    """
    return MgraoVectorEnv(system, seeds, episodes, reward=reward, flatten=flatten, **params)


class MgraoParallelEnv(ParallelEnv):
    """The world of a system as a PettingZoo ``ParallelEnv`` (module docstring: agents, spaces, seeds).

    One world of :class:`MgraoVectorEnv`, without the world axis. Build it with :func:`parallel_env`.

    Attributes:
        system: the preset it starts from.
        params: the full parameter set (preset plus overrides).
        seed: the seed of the world the first ``reset()`` without one gives.
        episodes: steps before truncation.
        reward: ``"child"`` or ``"team"`` (module docstring: "Reward").
        flatten: observations as one array (:func:`flat_length`) instead of a ``Dict``.
    """

    metadata = {"name": "mgrao_v0", "render_modes": [], "is_parallelizable": True}

    def __init__(self, system: str = "single", seed: int = 0, episodes: int = 100, *, reward: str = "child",
                 flatten: bool = False, **params: Any) -> None:
        self.seed = _seed(seed)
        self._vector = MgraoVectorEnv(system, [self.seed], episodes, reward=reward, flatten=flatten, **params)
        self.system, self.params, self.episodes = system, self._vector.params, self._vector.episodes
        self.reward, self.flatten = self._vector.reward, self._vector.flatten
        self.render_mode = None
        self.possible_agents = list(self._vector.possible_agents)
        self.agents: list[str] = []
        self._observation_spaces = dict.fromkeys(self.possible_agents,
                                                 observation_space(self.params, self.episodes, (), self.flatten))
        self._shape = action_shape(self.params)
        self._action_spaces = {agent: WeightsSpace(self._shape) for agent in self.possible_agents}
        self.state_space = state_space(self.params, self.episodes)
        self._generator: np.random.Generator | None = None

    def observation_space(self, agent: str) -> spaces.Space:
        """The child's observation space (the same object on every call)."""
        return self._observation_spaces[agent]

    def state(self) -> np.ndarray:
        """The state for centralised training (:attr:`state_space`; :meth:`MgraoVectorEnv.state`, one world)."""
        return self._vector.state()[0]

    def action_space(self, agent: str) -> spaces.Box:
        """The child's action space (the same object on every call)."""
        return self._action_spaces[agent]

    @property
    def world_seed(self) -> int | None:
        """The engine's seed whose world the current episodes run in (None before the first reset)."""
        seeds = self._vector.world_seeds
        return None if seeds is None else seeds[0]

    @property
    def episode(self) -> int:
        """Episodes played since the last reset."""
        return self._vector.episode

    def reset(self, seed: int | None = None, options: dict | None = None) -> tuple[dict, dict]:
        """Start the world of the engine's seed ``seed`` at episode 0.

        Without a seed, a fresh world drawn from the environment's own generator, which the last
        ``reset(seed=...)`` seeded (Gymnasium's convention); the first ``reset()`` without any seed before it
        gives the constructor's ``seed`` and seeds the generator with it.

        Returns:
            Each child's observation (nothing received yet: every entry of what came back is 0) and an
            empty info.

        Raises:
            ConfigError: a bad seed, or ``options`` that are no dict or ask for ``reset_mask`` (a partial reset,
                which one world cannot have), naming it; nothing is reset. Other keys are ignored (module docstring).
        """
        _options(options, vector=False)
        if seed is not None:
            world_seed = _seed(seed)
            self._generator = np.random.default_rng(world_seed)
        elif self._generator is None:
            world_seed = self.seed
            self._generator = np.random.default_rng(world_seed)
        else:
            world_seed = int(self._generator.integers(0, MAX_SEED_VALUE, endpoint=True))
        observations, infos = self._vector.reset(seed=[world_seed])
        self.agents = list(self._vector.agents)
        return {agent: _first(observation) for agent, observation in observations.items()}, infos

    def allocation(self, action: Any, agent: str = "") -> np.ndarray:
        """The weights an action stands for (:func:`allocations`).

        Raises:
            ValueError: not finite values at least 0 of the action's shape (the message names the agent).
        """
        n_types, shape = self.params.n_types, self._shape
        weights = allocations(action, agent, n_types)
        if weights.shape != shape:
            raise ValueError(f"{agent}: an action is {n_types} weights, one per atomic type"
                             f"{'' if self.params.n_resources == 1 else ', for each resource'}, shape "
                             f"{shape} (got shape {weights.shape})")
        return weights

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """One episode, each child holding the allocation its action gives.

        Returns:
            observations, rewards, terminations, truncations and infos, keyed by child.

        Raises:
            RuntimeError: before :meth:`reset`, or after the last episode.
            ValueError: a child without an action, an agent that is none, or an action that is not one
                (:meth:`allocation`); nothing is stepped.
        """
        vector = self._vector
        entries, rewards, utility, agents = vector._play(vector._allocations(actions, self.allocation))
        self.agents = list(vector.agents)
        done, value, episode = not self.agents, float(utility[0]), vector.episode - 1
        return (vector._observations(entries, agents, world=0),
                {agent: float(rewards[c, 0]) for c, agent in enumerate(agents)},
                dict.fromkeys(agents, False), dict.fromkeys(agents, done),
                {agent: {"utility": value, "episode": episode} for agent in agents})

    def render(self) -> None:
        """Nothing to render (the dashboard shows runs)."""

    def close(self) -> None:
        """Nothing to release."""


def _first(observation: dict[str, np.ndarray] | np.ndarray) -> dict[str, np.ndarray] | np.ndarray:
    if isinstance(observation, np.ndarray):
        return observation[0]
    return {key: value[0] for key, value in observation.items()}


def parallel_env(system: str = "single", seed: int = 0, episodes: int = 100, *, reward: str = "child",
                 flatten: bool = False, **params: Any) -> MgraoParallelEnv:
    """The world the engine simulates for ``system`` with ``params`` on top, as a PettingZoo ``ParallelEnv``.

    Args:
        system: a preset (``GET /api/systems`` lists them).
        seed: the engine's seed whose world the first ``reset()`` without a seed gives.
        episodes: steps (episodes) before truncation.
        reward: ``"child"`` (what came back to the child) or ``"team"`` (the system utility, for every child).
        flatten: observations as one array of :func:`flat_length` numbers instead of a ``Dict``.
        **params: parameter overrides, as ``--set name=value`` (docs/model.md).

    Raises:
        ConfigError: an unknown system or parameter, a value outside its limits, or a bad reward (naming it).
    """
    return MgraoParallelEnv(system, seed, episodes, reward=reward, flatten=flatten, **params)


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
        """Start the world of the engine's seed ``seed`` (without one, as :meth:`MgraoParallelEnv.reset`).

        Raises:
            ConfigError: as :meth:`MgraoParallelEnv.reset` (``options`` naming ``reset_mask``); nothing is reset.
        """
        _options(options, vector=False)
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
