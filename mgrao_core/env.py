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
  episodes played. With ``flatten=True`` the observation is one ``Box`` of :func:`flat_length`
  numbers, these entries flattened in the order of :data:`OBSERVATION_KEYS`. The floating-point entries
  (``value``, ``allocation``, ``resources``, and the flat form) are float64, or float32 with
  ``dtype=np.float32``, their spaces to match.
* **Reward**: the sum of the absolute values returned to the child in the episode (added in the
  order they came back); with ``reward="team"``, the system utility, for every child.
* **State** (``state()``, ``state_space``), for centralised training: every child's flat observation in
  agent order, then each parent's presence (1 or 0) in the last episode.
* **Infos**: ``{"utility": system utility of the episode, "episode": its index from 0}``, the same
  for every child (empty at reset); :class:`MgraoSingleChildEnv`, a Gymnasium ``Env``, gives the index as
  ``"episode_index"`` (:data:`GYMNASIUM_INFO`).
* **Seeds**: ``reset(seed=s)`` gives the world of the engine's seed ``s``, with the same draws
  (common random numbers); ``reset()`` without a seed draws a fresh world from the environment's
  generator, seeded by the last ``reset(seed=...)`` (Gymnasium's convention); the first ``reset()``
  without any gives the constructor's ``seed``.
* **Reset options**: the one-world environments take none: they refuse ``reset_mask`` (Gymnasium's option to
  reset some worlds only; a reset starts their one world) and ignore other keys, as PettingZoo's API test
  requires (it resets with ``options={"options": 1}``). The vector environment takes ``reset_mask`` and refuses
  any other option naming it. Nothing is reset by a refused call.
* **Learning cost**: under a ``learning_cost`` (docs/model.md, "The cost of learning") the caller declares what
  its learner keeps, ``learned_numbers``: the numbers one child keeps (as :meth:`Family.learned_numbers
  <mgrao_core.algorithms.base.Family.learned_numbers>` for a built-in family), one for every child, one per
  child, or in the vector environment one per world and child; settable between steps. Each child's tasks then
  get the share :func:`task_shares` of its allocation, as the engine gives a family's children (the action and
  the ``allocation`` observed are the weights themselves). A cost without a declaration is refused.
* **Many worlds** (:func:`vector_env`): the same, world ``i`` being the engine's seed ``seeds[i]``, with
  a leading axis of length ``n_worlds`` on every action ``(n_worlds, n_types)``, observation entry,
  reward, termination, truncation and info entry, and on the spaces. ``reset(seed=s)`` with a whole
  number gives the worlds of seeds ``s, s + 1, ...`` (Gymnasium's vector convention), with a list, those
  seeds (None in it: a fresh world there); ``reset()`` fresh worlds, world ``i``'s drawn from its own generator
  as ``parallel_env(seed=seeds[i])`` draws (the first ``reset()``: the constructor's seeds). World ``i`` is that
  ``parallel_env`` step for step, through every reset and autoreset.
* **Gymnasium's vector conventions**, where they have a meaning for many agents (Gymnasium 1.x ``VectorEnv``):
  ``num_envs`` (``n_worlds``); ``single_observation_space(agent)`` and ``single_action_space(agent)``, one world's
  spaces per agent (methods, as PettingZoo's spaces are), the batched ones Gymnasium's ``batch_space`` of them;
  ``metadata["autoreset_mode"]`` (``autoreset_mode=``, a ``gymnasium.vector.AutoresetMode``): next-step (the
  default: the step after a world's last episode starts it afresh, returning its reset observation, reward 0,
  no termination or truncation and no info, its action unused), same-step (the world starts afresh in the step
  that ended it: the fresh observation, that step's reward and truncation, ``final_obs`` and ``final_info`` in
  its infos with their masks) or disabled (a world that ended must be reset before a step);
  ``reset(options={"reset_mask": mask})`` resets the worlds where the boolean ``mask`` is True (the others go on
  as they were); each info key has Gymnasium's mask (``"_utility"``: the worlds whose info it is); ``call`` and
  ``get_attr`` answer per world. What stays different: everything is keyed by agent (a dict of per-world
  arrays, as PettingZoo's parallel API); every child acts in every world; ``agents`` empties when every world
  ended at once (PettingZoo's loops ``while env.agents`` stop there, and under next-step autoreset the next step
  starts them afresh), while worlds reset apart end apart and ``agents`` stays full.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from mgrao_core import equations as eq
from mgrao_core.algorithms import learned_by_max
from mgrao_core.errors import ConfigError
from mgrao_core.params import SystemParams, make_params
from mgrao_core.presets import get_preset
from mgrao_core.spec import MAX_SEED_VALUE
from mgrao_core.stepper import SteppedWorlds

try:
    import gymnasium
    from gymnasium import spaces
    from gymnasium.vector import AutoresetMode
    from gymnasium.vector.utils import batch_space
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
DTYPES = (np.dtype(np.float64), np.dtype(np.float32))
"""The observations' numbers: float64 (the default, the engine's) or float32 (most learners' own)."""
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

    A ``learning_cost`` is taken here; the environments price it only with the numbers the caller's learner
    keeps (``learned_numbers``, :func:`task_shares`).
    """
    return make_params(params, base=get_preset(system).params)


def _learned(value: Any, n_worlds: int, n_children: int, *, per_world: bool) -> np.ndarray | None:
    """``learned_numbers`` as ``(n_worlds, n_children)`` whole numbers, or None (module docstring: "Learning cost")."""
    if value is None:
        return None
    given = np.asarray(value, dtype=object if isinstance(value, list | tuple) else None)
    shapes = [(), (n_children,)] + ([(n_worlds, n_children)] if per_world else [])
    listed = given.ravel().tolist()
    whole = all(isinstance(x, int | np.integer) and not isinstance(x, bool | np.bool_) and x >= 0 for x in listed)
    if given.shape not in shapes or not whole:
        forms = "a whole number for every child, one per child" + (", or one per world and child" if per_world else "")
        raise ConfigError("learned_numbers", f"must be {forms}: the numbers at least 0 that one child of your learner "
                                             f"keeps, shape {' or '.join(map(str, shapes))} (got {str(value)[:80]})")
    return np.broadcast_to(np.array(listed, dtype=np.int64).reshape(given.shape), (n_worlds, n_children)).copy()


def task_shares(params: SystemParams, learned: np.ndarray | None) -> np.ndarray:
    """The share of each child's resources its tasks get, what learning ``learned`` numbers leaves them.

    As the engine prices a built-in family's children (:func:`mgrao_core.algorithms.task_share`): each number
    through :func:`mgrao_core.equations.task_share` against what ``mgrao-max`` keeps, so that a learner declaring
    a family's :meth:`~mgrao_core.algorithms.base.Family.learned_numbers` gets that family's share, bit for bit.
    1 everywhere without a cost or a declaration. ``learned`` is an integer array of any shape; so is the answer.
    """
    if learned is None or not params.learning_cost:
        return np.ones(() if learned is None else learned.shape)
    yardstick = learned_by_max(params)
    share = {n: eq.task_share(params.learning_cost, n, yardstick) for n in np.unique(learned).tolist()}
    return np.array([share[n] for n in learned.ravel().tolist()], dtype=np.float64).reshape(learned.shape)


def _dtype(value: Any) -> np.dtype:
    try:
        dtype = np.dtype(value)
    except TypeError:
        dtype = None
    if dtype not in DTYPES:
        raise ConfigError("dtype", f"must be float64 or float32, the observations' numbers (got {value!r})")
    return dtype


def _autoreset(value: Any) -> AutoresetMode:
    try:
        return value if isinstance(value, AutoresetMode) else AutoresetMode(value)
    except ValueError:
        raise ConfigError("autoreset_mode", f"must be one of {', '.join(m.value for m in AutoresetMode)} (a "
                                            f"gymnasium.vector.AutoresetMode or its value; got {value!r})") from None


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
"""Gymnasium's vector option to reset some worlds only (``options={"reset_mask": mask}``)."""


def _options(options: Any, *, vector: bool, n_worlds: int = 1) -> np.ndarray | None:
    """The worlds a reset's options ask for (``reset_mask``), None for every world; refuse what would not be honoured.

    The vector environment takes ``reset_mask`` alone, a boolean array of one entry per world with at least one
    True (Gymnasium's checks), and refuses any other option naming it. The one-world environments refuse
    ``reset_mask`` (they have one world: a reset starts it) and ignore other keys, as PettingZoo's API test
    requires of them (it resets with ``options={"options": 1}``). The caller's dict is left as it is.
    """
    if options is None:
        return None
    if not isinstance(options, dict):
        raise ConfigError("options", f"must be a dict of options or None (got {type(options).__name__})")
    if not vector:
        if PARTIAL_RESET in options:
            raise ConfigError("options", f"unknown option {PARTIAL_RESET}: one world, which a reset starts (a vector "
                                         "environment's worlds can be reset apart)")
        return None
    refused = sorted(str(key) for key in options if key != PARTIAL_RESET)
    if refused:
        raise ConfigError("options", f"unknown option{'s' if len(refused) > 1 else ''} {', '.join(refused)}: this "
                                     f"environment takes {PARTIAL_RESET} only")
    if PARTIAL_RESET not in options:
        return None
    given = options[PARTIAL_RESET]
    mask = np.asarray(given) if isinstance(given, np.ndarray | list | tuple) else None
    if mask is None or mask.dtype != np.bool_ or mask.shape != (n_worlds,) or not mask.any():
        raise ConfigError(f"options.{PARTIAL_RESET}", f"must be {n_worlds} booleans, one per world, at least one True "
                                                      f"(the worlds to reset; got {str(given)[:80]})")
    return mask


def _reset_seeds(value: Any, n_worlds: int) -> list[int | None]:
    """A reset's seeds, one per world (None: a fresh world): None, ``s`` for ``s, s + 1, ...``, or a list.

    A list may hold None for a world that takes a fresh one; its seeds must not repeat.
    """
    if value is None:
        return [None] * n_worlds
    if isinstance(value, list | tuple) and any(s is None for s in value):
        if len(value) != n_worlds:
            raise ConfigError("seed", f"must be {n_worlds} seeds, one per world (got {len(value)})")
        given = [(i, _seed(s, f"seed[{i}]")) for i, s in enumerate(value) if s is not None]
        if len({s for _, s in given}) != len(given):
            raise ConfigError("seed", "must not repeat a seed")
        seeds: list[int | None] = [None] * n_worlds
        for i, s in given:
            seeds[i] = s
        return seeds
    return list(_seeds(value, n_worlds, "seed"))


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


def observation_space(params: SystemParams, episodes: int, flatten: bool = False,
                      dtype: Any = np.float64) -> spaces.Space:
    """A child's observation space in one world (module docstring: "Observation").

    A ``Dict`` of :data:`OBSERVATION_KEYS` (``value``, ``allocation`` and ``resources`` of ``dtype``), or with
    ``flatten`` one ``Box`` of :func:`flat_length` numbers of ``dtype``: the entries flattened in that order. Many
    worlds' is Gymnasium's batching of it (``gymnasium.vector.utils.batch_space``).
    """
    grid = (params.n_parents, params.types_per_composite)
    types = action_shape(params)
    if flatten:
        bounds = _entry_bounds(params, episodes).values()
        low = np.concatenate([np.full(size, low, dtype) for low, _, size in bounds])
        high = np.concatenate([np.full(size, high, dtype) for _, high, size in bounds])
        return spaces.Box(low, high, low.shape, dtype)
    return spaces.Dict({
        "received": spaces.MultiBinary(list(grid)),
        "task_type": spaces.MultiDiscrete(np.full(grid, params.n_types, dtype=np.int64)),
        "value": spaces.Box(0.0, 1.0, grid, dtype),
        "position": spaces.MultiDiscrete(np.full(grid, grid[0] * grid[1], dtype=np.int64)),
        "allocation": spaces.Box(0.0, 1.0, types, dtype),
        "resources": spaces.Box(0.0, np.inf, types, dtype),
        "episode": spaces.MultiDiscrete(np.full(1, episodes + 1, dtype=np.int64)),
    })


def state_space(params: SystemParams, episodes: int, batch: tuple[int, ...] = (),
                dtype: Any = np.float64) -> spaces.Box:
    """The state's space: every child's flat observation in agent order, then each parent's presence (0 or 1)."""
    child = observation_space(params, episodes, flatten=True, dtype=dtype)
    low = np.concatenate([np.tile(child.low, params.n_children), np.zeros(params.n_parents, dtype)])
    high = np.concatenate([np.tile(child.high, params.n_children), np.ones(params.n_parents, dtype)])
    shape = (*batch, low.size)
    return spaces.Box(np.broadcast_to(low, shape), np.broadcast_to(high, shape), shape, dtype)


class MgraoVectorEnv(ParallelEnv):
    """Many worlds of a system, stepped together on the compiled engine (module docstring: "Many worlds").

    A PettingZoo ``ParallelEnv`` with a leading world axis, following Gymnasium's ``VectorEnv`` wherever a
    convention has a meaning for many agents (module docstring: "Gymnasium's vector conventions"). Build it with
    :func:`vector_env`.

    Attributes:
        system: the preset it starts from.
        params: the full parameter set (preset plus overrides).
        seeds: the engine's seeds of the worlds the first ``reset()`` without a seed gives.
        n_worlds: how many worlds step at once; ``num_envs`` is the same number (Gymnasium's name).
        episodes: steps before a world is truncated.
        reward: ``"child"`` or ``"team"`` (module docstring: "Reward").
        flatten: observations as one array (:func:`flat_length`) instead of a ``Dict``.
        dtype: the observations' floating-point numbers, float64 or float32.
        autoreset_mode: what a world does after its last episode (``metadata["autoreset_mode"]``).
    """

    metadata = {"name": "mgrao_vector_v0", "render_modes": [], "is_parallelizable": True,
                "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, system: str = "single", seeds: Any = range(64), episodes: int = 100, *, reward: str = "child",
                 flatten: bool = False, dtype: Any = np.float64, autoreset_mode: Any = AutoresetMode.NEXT_STEP,
                 learned_numbers: Any = None, **params: Any) -> None:
        self.system = system
        self.params = p = system_params(system, params)
        self.seeds = _seeds(seeds, None)
        self.n_worlds = self.num_envs = len(self.seeds)
        self.episodes = _episodes(episodes)
        self.reward = _reward(reward)
        self.flatten = bool(flatten)
        self.dtype = _dtype(dtype)
        self.autoreset_mode = _autoreset(autoreset_mode)
        self.metadata = {**type(self).metadata, "autoreset_mode": self.autoreset_mode}
        self.render_mode = None
        self.possible_agents = [f"child_{c}" for c in range(p.n_children)]
        self.agents: list[str] = []
        self._index = {agent: c for c, agent in enumerate(self.possible_agents)}
        self._world_index: dict[int, dict[str, tuple[int, int]]] = {}  # one world's entries (_observations)
        n = self.n_worlds
        single = observation_space(p, self.episodes, self.flatten, self.dtype)
        self._single_observation_spaces = dict.fromkeys(self.possible_agents, single)
        self._observation_spaces = dict.fromkeys(self.possible_agents, batch_space(single, n))  # Gymnasium's batching
        self._single_action_spaces = {agent: WeightsSpace(action_shape(p)) for agent in self.possible_agents}
        self._action_spaces = {agent: WeightsSpace((n, *action_shape(p))) for agent in self.possible_agents}
        self.state_space = state_space(p, self.episodes, (n,), self.dtype)
        self._worlds: SteppedWorlds | None = None
        self._generators: list[np.random.Generator | None] = [None] * n  # each world's, seeded by its last seed
        self._last: dict[str, np.ndarray] = {}
        self._done = np.zeros(n, np.bool_)  # the worlds whose last episode ended at the last step, not reset since
        self._ended = False  # any of them
        self._learned: np.ndarray | None = None
        self._task_share = np.ones((n, p.n_children))
        self.learned_numbers = learned_numbers

    # ---- spaces -------------------------------------------------------------------------------------------

    def observation_space(self, agent: str) -> spaces.Space:
        """The child's observation space, a leading world axis on every entry (the same object on every call)."""
        return self._observation_spaces[agent]

    def single_observation_space(self, agent: str) -> spaces.Space:
        """The child's observation space in one world (Gymnasium's ``single_observation_space``, per agent)."""
        return self._single_observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        """The child's action space, ``(n_worlds, n_types)`` or ``(n_worlds, R, n_types)`` (the same object)."""
        return self._action_spaces[agent]

    def single_action_space(self, agent: str) -> spaces.Box:
        """The child's action space in one world (Gymnasium's ``single_action_space``, per agent)."""
        return self._single_action_spaces[agent]

    # ---- the learner's cost of learning ---------------------------------------------------------------------

    @property
    def learned_numbers(self) -> np.ndarray | None:
        """The numbers each child of the caller's learner keeps, ``(n_worlds, n_children)`` (None: undeclared).

        Setting it (a whole number, one per child, or one per world and child) prices the learning from the next
        episode on (:func:`task_shares`), as the engine prices a built-in family's children.

        Raises:
            ConfigError: naming ``learned_numbers``: not whole numbers at least 0 of one of those shapes, or None
                under a ``learning_cost`` (the environment cannot price a learner that does not say what it keeps).
        """
        return None if self._learned is None else self._learned.copy()

    @learned_numbers.setter
    def learned_numbers(self, value: Any) -> None:
        learned = _learned(value, self.n_worlds, len(self.possible_agents), per_world=True)
        if learned is None and self.params.learning_cost:
            raise ConfigError("learned_numbers", "must be declared under a learning_cost: the numbers one child of "
                                                 "your learner keeps (as Family.learned_numbers for a built-in family; "
                                                 "docs/model.md, 'The cost of learning')")
        self._learned = learned
        self._task_share = np.broadcast_to(task_shares(self.params, learned),
                                           (self.n_worlds, len(self.possible_agents))).copy()
        if self._worlds is not None:
            self._worlds.set_task_share(self._task_share)

    @property
    def task_share(self) -> np.ndarray:
        """``(n_worlds, n_children)`` the share of each child's resources its tasks get (1: no learning cost)."""
        return self._task_share.copy()

    # ---- observations and state ---------------------------------------------------------------------------

    def state(self) -> np.ndarray:
        """The state for centralised training, ``(n_worlds, len)`` (:attr:`state_space`).

        Every child's flat observation in agent order, then each parent's presence (1 present, 0 absent) in
        the last episode.
        """
        if self._worlds is None:
            raise RuntimeError("call reset() first: there is no state before it")
        flat = self._flat(self._last)  # (children, worlds, flat_length)
        children = flat.transpose(1, 0, 2).reshape(self.n_worlds, -1)
        return np.concatenate([children, self._worlds.present.astype(self.dtype)], axis=1)

    def _flat(self, entries: dict[str, np.ndarray]) -> np.ndarray:
        n_children = len(self.possible_agents)
        return np.concatenate([entries[key].reshape(n_children, self.n_worlds, -1).astype(self.dtype)
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
        each child's resources and the episodes each world has played.
        """
        n_children = len(self.possible_agents)
        together = self._worlds.played_together
        if together is None:
            episode = np.empty((n_children, self.n_worlds, 1), np.int64)
            episode[:] = self._worlds.played[None, :, None]
        else:
            episode = np.full((n_children, self.n_worlds, 1), together, np.int64)
        if self.dtype != np.float64:
            returned["value"] = returned["value"].astype(self.dtype)
        return returned | {
            "allocation": weights.swapaxes(0, 1).astype(self.dtype, order="C"),
            "resources": self._resources.copy(),
            "episode": episode}

    def _nothing(self) -> dict[str, np.ndarray]:
        """The entries of a reset: nothing received, no allocation, each world's resources, no episode played."""
        p = self.params
        grid = (len(self.possible_agents), self.n_worlds, p.n_parents, p.types_per_composite)
        nothing = {"received": np.zeros(grid, np.int8), "task_type": np.zeros(grid, np.int64),
                   "value": np.zeros(grid), "position": np.zeros(grid, np.int64)}
        return self._entries(nothing, np.zeros((self.n_worlds, len(self.possible_agents), *action_shape(p))))

    def _blank(self, entries: dict[str, np.ndarray], rows: np.ndarray) -> None:
        """Make worlds ``rows`` of ``entries`` a reset's (:meth:`_nothing`), in place."""
        for key in (*RETURNED_KEYS, "allocation", "episode"):
            entries[key][:, rows] = 0
        entries["resources"][:, rows] = self._resources[:, rows]

    @property
    def world_seeds(self) -> tuple[int, ...] | None:
        """The engine's seeds of the worlds under way (None before the first reset)."""
        return None if self._worlds is None else self._worlds.seeds

    @property
    def world_episodes(self) -> np.ndarray:
        """``(n_worlds,)`` the episodes each world has played since it began (0 before the first reset)."""
        return np.zeros(self.n_worlds, np.int64) if self._worlds is None else self._worlds.played

    @property
    def episode(self) -> int:
        """Steps since the last reset of every world (each world's own count: :attr:`world_episodes`)."""
        return 0 if self._worlds is None else self._worlds.episode

    # ---- reset --------------------------------------------------------------------------------------------

    def reset(self, seed: Any = None, options: dict | None = None) -> tuple[dict, dict]:
        """Start the worlds of ``seed``, or with ``options={"reset_mask": mask}`` those where ``mask`` is True.

        ``seed``: a list of seeds, one per world (None in it: a fresh world for that one), ``s`` for ``s, s + 1,
        ...``, or None: fresh worlds, each drawn from its world's own generator, which that world's last seed
        seeded (the first ``reset()`` without a seed gives the constructor's ``seeds``). With a mask, the seeds of
        the worlds reset are read and the others' ignored (Gymnasium's).

        Returns:
            Each child's observation of every world (a reset world's: nothing received, every entry of what came
            back 0; the others' as they were) and an empty info.

        Raises:
            ConfigError: bad seeds, ``options`` other than ``reset_mask`` (naming them), a mask that is not one
                boolean per world with a True, or a mask before the first reset; nothing is reset.
        """
        mask = _options(options, vector=True, n_worlds=self.n_worlds)
        seeds = _reset_seeds(seed, self.n_worlds)
        if mask is not None:
            if self._worlds is None:
                raise ConfigError(f"options.{PARTIAL_RESET}", "the first reset() starts every world: there is no "
                                                              "world to keep yet")
            rows = np.flatnonzero(mask)
            self._renew(rows, [seeds[i] for i in rows.tolist()])
            entries = {key: value.copy() for key, value in self._last.items()}
            self._blank(entries, rows)
            self._done[rows] = False
            self._ended = bool(self._done.any())
        else:
            world_seeds = [self._world_seed(i, s) for i, s in enumerate(seeds)]
            block = min(self.episodes, DRAW_BLOCK, max(1, DRAWN_WORLD_EPISODES // self.n_worlds))
            self._worlds = SteppedWorlds(self.params, world_seeds, block=block)
            self._worlds.set_task_share(self._task_share)
            self._resources = np.ascontiguousarray(np.moveaxis(self._worlds.resources, 1, 0), dtype=self.dtype)
            self._done[:] = False
            self._ended = False
            entries = self._nothing()
        self.agents = list(self.possible_agents)
        return self._observations(entries, self.agents), {agent: {} for agent in self.agents}

    def _world_seed(self, world: int, seed: int | None) -> int:
        """World ``world``'s next seed: ``seed``, which seeds its generator, or without one a draw from it.

        The first without any seed is the constructor's. The draws are :class:`MgraoParallelEnv`'s (world ``i`` is
        ``parallel_env(seed=seeds[i])``, unseeded resets included).
        """
        if seed is None:
            generator = self._generators[world]
            if generator is not None:
                return int(generator.integers(0, MAX_SEED_VALUE, endpoint=True))
            seed = self.seeds[world]
        self._generators[world] = np.random.default_rng(seed)
        return seed

    def _renew(self, rows: np.ndarray, seeds: list[int | None]) -> None:
        """Start worlds ``rows`` afresh, each of its seed (None: a fresh one, :meth:`_world_seed`)."""
        chosen = [self._world_seed(i, s) for i, s in zip(rows.tolist(), seeds, strict=True)]
        self._worlds.renew(rows, chosen)
        self._resources[:, rows] = np.moveaxis(self._worlds.resources[rows], 1, 0)

    # ---- call and get_attr ----------------------------------------------------------------------------------

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Each world's answer to ``name``, one per world (Gymnasium's ``VectorEnv.call``).

        A world answers as :class:`MgraoParallelEnv` of it would: ``world_seed``, ``seed`` (the constructor's),
        ``episode`` (its episodes played), ``learned_numbers`` (its children's), ``state()`` (its row),
        ``observation_space(agent)`` and ``action_space(agent)`` (one world's), ``render()`` (None); any other
        attribute that is no method (``params``, ``episodes``, ``possible_agents``...) is the same in every world.

        Raises:
            AttributeError: ``name`` is nothing a world answers on its own (stepping and resetting are the
                vector environment's).
        """
        n = self.n_worlds
        answers: dict[str, Callable[[], tuple[Any, ...]]] = {
            "world_seed": lambda: self.world_seeds or (None,) * n,
            "seed": lambda: self.seeds,
            "episode": lambda: tuple(self.world_episodes.tolist()),
            "learned_numbers": lambda: (None,) * n if self._learned is None else tuple(self._learned.copy()),
            "state": lambda: tuple(self.state(*args, **kwargs)),
            "observation_space": lambda: (self.single_observation_space(*args, **kwargs),) * n,
            "action_space": lambda: (self.single_action_space(*args, **kwargs),) * n,
            "render": lambda: (None,) * n,
        }
        if name in answers:
            return answers[name]()
        value = getattr(self, name, None) if isinstance(name, str) and not name.startswith("_") else None
        if value is None or callable(value):
            raise AttributeError(f"call: {name!r} is nothing a world answers on its own (a world answers "
                                 f"{', '.join(answers)} and the attributes every world shares, such as params)")
        return (value,) * n

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Each world's ``name`` (Gymnasium's ``VectorEnv.get_attr``: :meth:`call` without arguments)."""
        return self.call(name)

    # ---- step ---------------------------------------------------------------------------------------------

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
        if self._worlds is None:
            raise RuntimeError("call reset() first: no episode is under way")
        if self._ended and self.autoreset_mode is AutoresetMode.DISABLED:
            if self._done.all():
                raise RuntimeError("call reset() first: no episode is under way")
            raise RuntimeError(f"call reset() first: world{'s' if self._done.sum() > 1 else ''} "
                               f"{', '.join(map(str, np.flatnonzero(self._done).tolist()))} ended (autoreset is "
                               f"disabled: reset them with options={{'reset_mask': ...}})")
        if not isinstance(actions, dict):
            raise ValueError(f"actions must be a dict of the agents' actions (got {type(actions).__name__})")
        if actions.keys() != self._index.keys():  # every agent acts while any does
            self._refuse_agents(actions)
        read = read or self.allocation
        weights = np.empty((self.n_worlds, len(self.possible_agents), *action_shape(self.params)))
        for c, agent in enumerate(self.possible_agents):
            weights[:, c] = read(actions[agent], agent)
        return weights

    def _refuse_agents(self, actions: dict[str, Any]) -> None:
        """ValueError naming an agent of ``actions`` that is none, or an agent without an action."""
        unknown = [str(agent) for agent in actions if agent not in self._index]
        if unknown:
            raise ValueError(f"{', '.join(unknown)}: not an agent of this environment (agents: "
                             f"{self.possible_agents[0]} to {self.possible_agents[-1]})")
        missing = [agent for agent in self.possible_agents if agent not in actions]
        if missing:
            raise ValueError(f"no action for {', '.join(missing)}")

    def step(self, actions: dict[str, Any]) -> tuple[dict, dict, dict, dict, dict]:
        """One episode of every world, each child holding the allocation its action gives in each world.

        A world that ended at the last step starts afresh instead under next-step autoreset (its action is read
        and not used; module docstring: "Gymnasium's vector conventions").

        Returns:
            observations, rewards, terminations, truncations and infos, keyed by child, each value with a
            leading world axis.

        Raises:
            RuntimeError: before :meth:`reset`, or with autoreset disabled, while a world that ended is not reset.
            ValueError: a child without an action, an agent that is none, or an action that is not one
                (:meth:`allocation`); nothing is stepped.
        """
        return self._advance(self._allocations(actions))

    def _play(self, weights: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
        """One episode of every world with every child's weights read (:meth:`_allocations`).

        Marks the worlds whose last episode it was (:attr:`_done`); :attr:`agents` empties when that is every
        world and they are not reset at once (autoreset other than same-step).

        Returns:
            The observations' entries ``(children, worlds, ...)`` (kept for :meth:`state`), the rewards
            ``(children, worlds)`` and the system utility ``(worlds,)``.
        """
        outcome = self._worlds.step(weights)
        returned, rewards = self._worlds.observe(outcome)
        together = self._worlds.played_together
        if together is None:
            np.greater_equal(self._worlds.played, self.episodes, out=self._done)
            self._ended = bool(self._done.any())
        elif together >= self.episodes:
            self._done[:] = self._ended = True
            if self.autoreset_mode is not AutoresetMode.SAME_STEP:
                self.agents = []
        utility = outcome.utility.copy()
        if self.reward == "team":
            rewards = np.broadcast_to(utility, rewards.shape)
        self._last = self._entries(returned, weights)
        return self._last, rewards, utility

    def _advance(self, weights: np.ndarray) -> tuple[dict, dict, dict, dict, dict]:
        """:meth:`step` with every child's weights read (:meth:`_allocations`), autoreset included."""
        n, agents = self.n_worlds, self.possible_agents
        next_step = self.autoreset_mode is AutoresetMode.NEXT_STEP
        if next_step and self._ended and self._done.all():  # every world ended: all start afresh, none plays
            return self._restart()
        pending = np.flatnonzero(self._done) if next_step and self._ended else None
        entries, rewards, utility = self._play(weights)
        together = self._worlds.played_together
        index = np.full(n, together - 1) if together is not None else self._worlds.played - 1
        shown = np.ones(n, np.bool_)  # the worlds whose info is this episode's
        if pending is not None:  # they played beyond their end; they start afresh instead (next-step autoreset)
            self._renew(pending, [None] * len(pending))
            self._blank(entries, pending)
            rewards = rewards.copy()
            rewards[:, pending] = 0.0
            utility[pending] = 0.0
            index[pending] = 0
            shown[pending] = False
            self._done[pending] = False
            self._ended = bool(self._done.any())
            self.agents = list(agents)
        truncated = self._done.copy()
        infos = {agent: {"utility": utility.copy(), "_utility": shown.copy(), "episode": index.copy(),
                         "_episode": shown.copy()} for agent in agents}
        if self._ended and self.autoreset_mode is AutoresetMode.SAME_STEP:
            self._same_step(entries, infos, utility, index)
        return (self._observations(entries, agents),
                {agent: rewards[c].copy() for c, agent in enumerate(agents)},
                {agent: np.zeros(n, np.bool_) for agent in agents},
                {agent: truncated.copy() for agent in agents},
                infos)

    def _same_step(self, entries: dict[str, np.ndarray], infos: dict[str, dict], utility: np.ndarray,
                   index: np.ndarray) -> None:
        """Same-step autoreset: the worlds that ended start afresh now, their last observation and info kept.

        As Gymnasium's: ``infos[agent]["final_obs"]`` is an object array of each ended world's observation (None
        elsewhere), ``"final_info"`` its info, each with its mask (``"_final_obs"``, ``"_final_info"``), and the
        ended worlds' own entries are a reset's (no info).
        """
        rows = np.flatnonzero(self._done)
        ended = self._done.copy()
        final = self._observations(entries, self.possible_agents)
        for agent in self.possible_agents:
            observations = np.full(self.n_worlds, None, dtype=object)
            for i in rows.tolist():
                observations[i] = (final[agent][i].copy() if self.flatten
                                   else {key: value[i].copy() for key, value in final[agent].items()})
            info = infos[agent]
            info["final_info"] = {"utility": np.where(ended, utility, 0.0), "_utility": ended.copy(),
                                  "episode": np.where(ended, index, 0), "_episode": ended.copy()}
            info["final_obs"], info["_final_obs"], info["_final_info"] = observations, ended.copy(), ended.copy()
            for key in ("_utility", "_episode"):
                info[key][rows] = False
            info["utility"][rows] = 0.0
            info["episode"][rows] = 0
        self._renew(rows, [None] * len(rows))
        self._blank(entries, rows)
        self._done[:] = self._ended = False

    def _restart(self) -> tuple[dict, dict, dict, dict, dict]:
        """Next-step autoreset of every world at once: fresh worlds, nothing played, empty infos."""
        n, agents = self.n_worlds, self.possible_agents
        self._renew(np.arange(n), [None] * n)
        self._done[:] = self._ended = False
        self.agents = list(agents)
        entries = self._nothing()
        return (self._observations(entries, agents), {agent: np.zeros(n) for agent in agents},
                {agent: np.zeros(n, np.bool_) for agent in agents}, {agent: np.zeros(n, np.bool_) for agent in agents},
                {agent: {} for agent in agents})

    def render(self) -> None:
        """Nothing to render (the dashboard shows runs)."""

    def close(self) -> None:
        """Nothing to release."""


def vector_env(system: str = "single", seeds: Any = range(64), episodes: int = 100, *, reward: str = "child",
               flatten: bool = False, dtype: Any = np.float64, autoreset_mode: Any = AutoresetMode.NEXT_STEP,
               learned_numbers: Any = None, **params: Any) -> MgraoVectorEnv:
    """Many worlds of ``system`` with ``params`` on top, stepped together, as a batched PettingZoo ``ParallelEnv``.

    Args:
        system: a preset (``GET /api/systems`` lists them).
        seeds: the engine's seed of each world (world ``i`` is seed ``seeds[i]``, with its draws).
        episodes: steps (episodes) before a world is truncated.
        reward: ``"child"`` (what came back to the child) or ``"team"`` (the system utility, for every child).
        flatten: observations as one array of :func:`flat_length` numbers per world instead of a ``Dict``.
        dtype: the observations' floating-point numbers: float64 (the default) or float32, the spaces to match.
        autoreset_mode: a ``gymnasium.vector.AutoresetMode`` (or its value): next-step (the default), same-step or
            disabled.
        learned_numbers: what one child of your learner keeps, under a ``learning_cost`` (module docstring:
            "Learning cost").
        **params: parameter overrides, as ``--set name=value`` (docs/model.md).

    Raises:
        ConfigError: an unknown system or parameter, a value outside its limits, bad seeds, reward, dtype, autoreset
            mode or learned numbers, or a learning cost without learned numbers (naming it).
    """
    return MgraoVectorEnv(system, seeds, episodes, reward=reward, flatten=flatten, dtype=dtype,
                          autoreset_mode=autoreset_mode, learned_numbers=learned_numbers, **params)


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
                 flatten: bool = False, dtype: Any = np.float64, learned_numbers: Any = None, **params: Any) -> None:
        self.seed = _seed(seed)
        learned = _learned(learned_numbers, 1, system_params(system, params).n_children, per_world=False)
        self._vector = MgraoVectorEnv(system, [self.seed], episodes, reward=reward, flatten=flatten, dtype=dtype,
                                      autoreset_mode=AutoresetMode.DISABLED, learned_numbers=learned, **params)
        self.system, self.params, self.episodes = system, self._vector.params, self._vector.episodes
        self.reward, self.flatten, self.dtype = self._vector.reward, self._vector.flatten, self._vector.dtype
        self.render_mode = None
        self.possible_agents = list(self._vector.possible_agents)
        self.agents: list[str] = []
        self._observation_spaces = {agent: self._vector.single_observation_space(agent)
                                    for agent in self.possible_agents}
        self._shape = action_shape(self.params)
        self._action_spaces = {agent: self._vector.single_action_space(agent) for agent in self.possible_agents}
        self.state_space = state_space(self.params, self.episodes, (), self.dtype)

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
    def learned_numbers(self) -> np.ndarray | None:
        """What each child of the caller's learner keeps, ``(n_children,)`` (:attr:`MgraoVectorEnv.learned_numbers`).

        Setting it (a whole number, or one per child) prices the learning from the next episode on.
        """
        learned = self._vector.learned_numbers
        return None if learned is None else learned[0]

    @learned_numbers.setter
    def learned_numbers(self, value: Any) -> None:
        n_children = len(self.possible_agents)
        self._vector.learned_numbers = _learned(value, 1, n_children, per_world=False)

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
        observations, infos = self._vector.reset(seed=None if seed is None else [_seed(seed)])
        self.agents = list(self._vector.agents)
        return {agent: _first(observation) for agent, observation in observations.items()}, \
            {agent: {} for agent in self.agents}

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
        entries, rewards, utility = vector._play(vector._allocations(actions, self.allocation))
        agents = self.possible_agents
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
                 flatten: bool = False, dtype: Any = np.float64, learned_numbers: Any = None,
                 **params: Any) -> MgraoParallelEnv:
    """The world the engine simulates for ``system`` with ``params`` on top, as a PettingZoo ``ParallelEnv``.

    Args:
        system: a preset (``GET /api/systems`` lists them).
        seed: the engine's seed whose world the first ``reset()`` without a seed gives.
        episodes: steps (episodes) before truncation.
        reward: ``"child"`` (what came back to the child) or ``"team"`` (the system utility, for every child).
        flatten: observations as one array of :func:`flat_length` numbers instead of a ``Dict``.
        dtype: the observations' floating-point numbers: float64 (the default) or float32, the spaces to match.
        learned_numbers: what one child of your learner keeps, a whole number or one per child, under a
            ``learning_cost`` (module docstring: "Learning cost").
        **params: parameter overrides, as ``--set name=value`` (docs/model.md).

    Raises:
        ConfigError: an unknown system or parameter, a value outside its limits, a bad reward, dtype or learned
            numbers, or a learning cost without learned numbers (naming it).
    """
    return MgraoParallelEnv(system, seed, episodes, reward=reward, flatten=flatten, dtype=dtype,
                            learned_numbers=learned_numbers, **params)


GYMNASIUM_INFO = {"episode": "episode_index", "_episode": "_episode_index"}
"""Info keys renamed where the environment is seen as a Gymnasium one (:class:`MgraoSingleChildEnv`, an agent's
view of the vector environment in :mod:`mgrao_core.per_agent`): Gymnasium's ``RecordEpisodeStatistics`` writes its
statistics under ``"episode"`` and refuses an info that has one."""


def gymnasium_info(info: dict[str, Any]) -> dict[str, Any]:
    """An info as a Gymnasium environment gives it (:data:`GYMNASIUM_INFO`; a ``final_info`` in it too), a new dict."""
    renamed = {GYMNASIUM_INFO.get(key, key): value for key, value in info.items()}
    if isinstance(renamed.get("final_info"), dict):
        renamed["final_info"] = gymnasium_info(renamed["final_info"])
    return renamed


class MgraoSingleChildEnv(gymnasium.Env):
    """A one-child system as a Gymnasium ``Env``: the :class:`MgraoParallelEnv` of its only child.

    The spaces, reward and info are that child's (its episode's index as ``"episode_index"``: :data:`GYMNASIUM_INFO`);
    ``reset(seed=s)`` also gives the world of the
    engine's seed ``s`` (and seeds ``np_random``, which the environment itself never draws from).
    Build it with :func:`single_agent_env`.
    """

    metadata = {"render_modes": []}

    def __init__(self, system: str = "single", seed: int = 0, episodes: int = 100, *, dtype: Any = np.float64,
                 learned_numbers: Any = None, **params: Any) -> None:
        self.parallel = MgraoParallelEnv(system, seed, episodes, dtype=dtype, learned_numbers=learned_numbers, **params)
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
        return observations[a], rewards[a], terminations[a], truncations[a], gymnasium_info(infos[a])


def single_agent_env(system: str = "single", seed: int = 0, episodes: int = 100, *, dtype: Any = np.float64,
                     learned_numbers: Any = None, **params: Any) -> MgraoSingleChildEnv:
    """A one-child system's world as a Gymnasium ``Env`` (arguments as :func:`parallel_env`).

    Raises:
        ConfigError: as :func:`parallel_env`, or the system has more than one child.
    """
    return MgraoSingleChildEnv(system, seed, episodes, dtype=dtype, learned_numbers=learned_numbers, **params)
