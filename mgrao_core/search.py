"""Studies: a base experiment, a search space over the schema's parameters, a method and an objective.

A study is many experiments that differ in a few parameters. This module validates a study's
definition against the parameter schema and the experiment limits, and says what each trial
runs: a grid's cells in order, or points drawn at random or by Optuna's TPE sampler (driven by
ask/tell on an in-memory Optuna study rebuilt from the finished trials, so that Optuna keeps no
tables of its own). It holds no state and does no I/O; the service stores the trials and runs
each as ordinary jobs (:mod:`backend.services.studies`).

Dimensions: any numeric, boolean or choice parameter of :data:`mgrao_core.params.PARAMETERS`,
``groups``, the x of an extra configuration ``mgrao-x:1``, and ``team_size``, its y (``mgrao-x:y``: children
sharing one model; x is 1 without a ``groups`` dimension). A dimension is ``{"values": [...]}``, or a
range ``{"low", "high"}`` with ``"steps"`` (grid) and optionally ``"log": true`` (geometric steps, or
log-uniform draws for random and TPE).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mgrao_core.algorithms import divisors
from mgrao_core.errors import ConfigError
from mgrao_core.params import PARAMETERS_BY_NAME
from mgrao_core.presets import PRESETS
from mgrao_core.spec import MAX_EPISODES, MAX_SEED_VALUE, MAX_SEEDS, ExperimentSpec, make_spec
from mgrao_core.statistics.sequential import Until, make_until
from mgrao_core.statistics.summary import ConfigSummary

METHODS = ("grid", "random", "tpe")
METRICS = ("final_mean", "pct_from_uniform", "pct_of_max", "paper_deviation")
DIRECTIONS = ("maximize", "minimize")
GROUPS = "groups"
TEAM = "team_size"
GROUP_LABEL = "mgrao-x:1"
"""The objective's name for the configuration a ``groups`` dimension adds."""
TEAM_LABEL = "mgrao-x:y"
"""The objective's name for the configuration ``groups`` and ``team_size`` dimensions add (either may be absent)."""
LABEL_DIMENSIONS = (GROUPS, TEAM)
"""The dimensions that are no parameter: the arguments of the configuration they add."""
MAX_TRIALS = 10_000
MAX_IN_FLIGHT = 100
MAX_DIMENSIONS = 8
MAX_VALUES = 1_000
MAX_STEPS = 1_000
TPE_HISTORY = 1_000
"""TPE is told the latest this many finished trials (its cost per suggestion grows with them)."""


@dataclass(frozen=True)
class Dimension:
    """One dimension of a search space.

    Attributes:
        name: a parameter name, ``"groups"`` or ``"team_size"``.
        kind: ``"int"``, ``"float"``, ``"bool"`` or ``"choice"``.
        values: explicit values (a grid's points, or the choices drawn from), or empty.
        low: a range's lower end.
        high: a range's upper end.
        steps: a range's points on a grid.
        log: geometric steps, or log-uniform draws.
    """

    name: str
    kind: str
    values: tuple = ()
    low: float | None = None
    high: float | None = None
    steps: int | None = None
    log: bool = False

    def grid(self) -> tuple:
        """The dimension's points on a grid."""
        if self.values:
            return self.values
        assert self.low is not None and self.high is not None and self.steps is not None
        points = (np.geomspace(self.low, self.high, self.steps) if self.log
                  else np.linspace(self.low, self.high, self.steps))
        if self.kind == "int":
            return tuple(dict.fromkeys(int(round(v)) for v in points))
        return tuple(float(f"{v:.6g}") for v in points)  # as shown: 6 significant digits

    def as_dict(self) -> dict[str, Any]:
        """The dimension as given back (for storage and the API)."""
        if self.values:
            return {"values": list(self.values)}
        out: dict[str, Any] = {"low": self.low, "high": self.high, "log": self.log}
        if self.steps is not None:
            out["steps"] = self.steps
        return out


@dataclass(frozen=True)
class Objective:
    """What a trial is judged by.

    Attributes:
        metric: one of :data:`METRICS`.
        direction: ``"maximize"`` or ``"minimize"``.
        configuration: the algorithm label the metric is read from (``mgrao-x:1`` for the swept
            group count, ``mgrao-x:y`` for the swept group count and team size); unused by ``paper_deviation``.
        system: which system's configuration, when the base has several.
    """

    metric: str
    direction: str
    configuration: str | None = None
    system: str | None = None


@dataclass(frozen=True)
class StudyPlan:
    """A validated study (build it with :func:`make_plan`)."""

    name: str
    method: str
    systems: tuple[str, ...]
    algorithms: tuple[str, ...] | None
    seeds: tuple[int, ...]
    episodes: int
    params: dict[str, Any]
    dimensions: tuple[Dimension, ...]
    objective: Objective
    max_trials: int
    max_in_flight: int
    seed: int = 0
    _cells: int = field(default=0, compare=False)
    until: Until | None = None
    """Every trial's jobs run seeds in blocks from the first until this rule answers (``seeds`` are then the
    ``max_seeds`` they may run): a trial's objective decided to a stated precision (docs/studies.md)."""
    variants: dict[str, tuple[str, dict[str, Any]]] = field(default_factory=dict)
    """The base's named systems that are no preset (saved systems, inlined when the study was made): name ->
    (preset, overrides). Each runs its preset with its overrides, the base's ``params`` and the trial's on top."""

    def preset_of(self, system: str) -> str:
        """The preset a system of the base runs (itself, or a named system's)."""
        return self.variants[system][0] if system in self.variants else system

    @property
    def planned_trials(self) -> int:
        """How many trials the study runs: every cell of a grid, else ``max_trials``."""
        return self.grid_size if self.method == "grid" else self.max_trials

    @property
    def grid_size(self) -> int:
        """The number of grid cells (the product of the dimensions' points)."""
        return math.prod(len(d.grid()) for d in self.dimensions)

    def cell(self, index: int) -> dict[str, Any]:
        """The parameters of grid cell ``index`` (row-major over the dimensions, in order)."""
        axes = [d.grid() for d in self.dimensions]
        point = {}
        for dimension, axis, stride in zip(self.dimensions, axes, _strides([len(a) for a in axes]), strict=True):
            point[dimension.name] = axis[(index // stride) % len(axis)]
        return point

    def suggest(self, first: int, count: int, finished: Sequence[tuple[Mapping[str, Any], float]] = (),
                running: Sequence[Mapping[str, Any]] = ()) -> list[dict[str, Any]]:
        """The parameters of trials ``first`` .. ``first + count - 1``.

        A grid's cells in order; random draws that depend only on the study's seed and the trial
        number; or TPE's suggestions given the ``finished`` trials' ``(params, objective)`` (the
        latest :data:`TPE_HISTORY` of them, in trial order) and the ``running`` trials' parameters
        (told to TPE as running, so that a batch does not pile onto one point: Optuna's constant
        liar). The same arguments give the same suggestions.
        """
        if self.method == "grid":
            return [self.cell(number) for number in range(first, first + count)]
        if self.method == "random":
            return [{d.name: _draw(d, np.random.default_rng([self.seed, number])) for d in self.dimensions}
                    for number in range(first, first + count)]
        return _tpe(self, first, count, finished[-TPE_HISTORY:], running)

    def specs(self, params: Mapping[str, Any]) -> list[ExperimentSpec]:
        """The experiments (one per system) a trial with these parameters runs."""
        return [self._spec(system, params) for system in self.systems]

    def named_specs(self, params: Mapping[str, Any]) -> list[tuple[str, ExperimentSpec]]:
        """:meth:`specs` with the base's name of each system (a named system's name, not its preset's)."""
        return [(system, self._spec(system, params)) for system in self.systems]

    def _spec(self, system: str, params: Mapping[str, Any], field_prefix: str = "") -> ExperimentSpec:
        preset, own = self.variants.get(system, (system, {}))
        overrides = dict(own) | dict(self.params) | {k: v for k, v in params.items() if k not in LABEL_DIMENSIONS}
        system = preset
        algorithms = list(self.algorithms or PRESETS[system].algorithms)
        label = added_label(params)
        if label is not None and label not in algorithms:
            algorithms.append(label)
        return make_spec(system, algorithms, list(self.seeds), self.episodes, overrides)

    def configuration_label(self, params: Mapping[str, Any]) -> str | None:
        """The algorithm label the objective reads for a trial with these parameters."""
        if self.objective.configuration in (GROUP_LABEL, TEAM_LABEL):
            return added_label(params)
        return self.objective.configuration

    def as_dict(self) -> dict[str, Any]:
        """The definition as stored and shown (round-trips through :func:`make_plan`)."""
        systems = [{"name": s, "system": self.variants[s][0], "params": dict(self.variants[s][1])}
                   if s in self.variants else s for s in self.systems]
        base: dict[str, Any] = {
            "system": systems if len(systems) > 1 or self.variants else systems[0],
            "seeds": list(self.seeds), "episodes": self.episodes, "params": dict(self.params),
        }
        if self.until is not None:  # the seeds follow from the rule
            del base["seeds"]
            base |= {"first_seed": self.seeds[0], "until": self.until.as_dict()}
        if self.algorithms is not None:
            base["algorithms"] = list(self.algorithms)
        objective = {"metric": self.objective.metric, "direction": self.objective.direction}
        if self.objective.configuration is not None:
            objective["configuration"] = self.objective.configuration
        if self.objective.system is not None:
            objective["system"] = self.objective.system
        return {"name": self.name, "method": self.method, "base": base,
                "space": {d.name: d.as_dict() for d in self.dimensions}, "objective": objective,
                "max_trials": self.max_trials, "max_in_flight": self.max_in_flight, "seed": self.seed}


def added_label(params: Mapping[str, Any]) -> str | None:
    """The configuration ``mgrao-x:y`` a trial's ``groups`` (x, else 1) and ``team_size`` (y, else 1) add, or None."""
    if GROUPS not in params and TEAM not in params:
        return None
    return f"mgrao-{int(params.get(GROUPS, 1))}:{int(params.get(TEAM, 1))}"


def _strides(lengths: list[int]) -> list[int]:
    strides, stride = [], 1
    for length in reversed(lengths):
        strides.append(stride)
        stride *= length
    return list(reversed(strides))


def _draw(dimension: Dimension, rng: np.random.Generator) -> Any:
    if dimension.values:
        return dimension.values[int(rng.integers(len(dimension.values)))]
    assert dimension.low is not None and dimension.high is not None
    if dimension.log:
        value = math.exp(rng.uniform(math.log(dimension.low), math.log(dimension.high)))
    else:
        value = rng.uniform(dimension.low, dimension.high)
    if dimension.kind == "int":
        return int(min(dimension.high, max(dimension.low, round(value))))
    return float(min(dimension.high, max(dimension.low, value)))


def _distributions(plan: StudyPlan) -> dict[str, Any]:
    from optuna.distributions import CategoricalDistribution, FloatDistribution, IntDistribution

    out = {}
    for d in plan.dimensions:
        if d.values:
            out[d.name] = CategoricalDistribution(list(d.values))
        elif d.kind == "int":
            out[d.name] = IntDistribution(int(d.low), int(d.high), log=d.log)
        else:
            out[d.name] = FloatDistribution(d.low, d.high, log=d.log)
    return out


def _tpe(plan: StudyPlan, first: int, count: int, finished: Sequence[tuple[Mapping[str, Any], float]],
         running: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    import optuna
    from optuna.trial import TrialState, create_trial

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    distributions = _distributions(plan)
    sampler = optuna.samplers.TPESampler(seed=(plan.seed * 1_000_003 + first) % 2**32, constant_liar=True)
    study = optuna.create_study(direction=plan.objective.direction, sampler=sampler)  # in memory, ours alone
    for params, value in finished:
        if value is not None and math.isfinite(value):
            study.add_trial(create_trial(params={k: params[k] for k in distributions},
                                         distributions=distributions, value=value))
    for params in running:
        study.add_trial(create_trial(params={k: params[k] for k in distributions}, distributions=distributions,
                                     state=TrialState.RUNNING))
    return [dict(study.ask(distributions).params) for _ in range(count)]  # each left running: the next avoids it


# ---- objectives ------------------------------------------------------------------------------


def evaluate(plan: StudyPlan, params: Mapping[str, Any],
             summaries: Mapping[str, Mapping[str, ConfigSummary]]) -> tuple[float | None, tuple[float, float] | None]:
    """A trial's objective and its 95% interval over seeds, from each system's summaries.

    ``final_mean``, ``pct_from_uniform`` and ``pct_of_max`` are the configuration's own figures
    (``pct_of_max`` has no interval). ``paper_deviation`` is the largest ``|ours - paper|`` over the
    paper's figures of the trial's systems, with the interval of that figure's ``|deviation|``.
    None when the figure cannot be computed (e.g. a uniform utility of zero).
    """
    from mgrao_core.reproduction import figures_of

    objective = plan.objective
    if objective.metric == "paper_deviation":
        figures = [f for system in plan.systems for f in figures_of(system, summaries[system])]
        if not figures:
            return None, None
        worst = max(figures, key=lambda f: abs(f.deviation))
        low, high = worst.ci95[0] - worst.paper, worst.ci95[1] - worst.paper
        if not (math.isfinite(low) and math.isfinite(high)):
            return abs(worst.deviation), None
        interval = (0.0 if low <= 0 <= high else min(abs(low), abs(high)), max(abs(low), abs(high)))
        return abs(worst.deviation), interval
    row = summaries[objective.system or plan.systems[0]].get(plan.configuration_label(params))
    if row is None:
        return None, None
    if objective.metric == "final_mean":
        return row.final_mean, _finite_pair(row.ci95)
    if objective.metric == "pct_from_uniform":
        return row.pct_from_uniform, _finite_pair(row.pct_ci95)
    return row.pct_of_max, None


def _finite_pair(pair: tuple[float, float] | None) -> tuple[float, float] | None:
    if pair is None or not all(v is not None and math.isfinite(v) for v in pair):
        return None
    return float(pair[0]), float(pair[1])


# ---- validation -------------------------------------------------------------------------------


def _number(field: str, value: Any, *, integer: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(field, f"must be a finite number (got {value!r})")
    if integer and not float(value).is_integer():
        raise ConfigError(field, f"must be a whole number (got {value!r})")
    return value


def _count(field: str, value: Any, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ConfigError(field, f"must be a whole number in [{low}, {high}] (got {value!r})")
    return value


def _dimension(name: str, spec: Any, method: str, n_parents: Sequence[int], n_children: Sequence[int]) -> Dimension:
    field = f"space.{name}"
    if not isinstance(spec, Mapping):
        raise ConfigError(field, 'must be {"values": [...]} or {"low": ..., "high": ...}')
    unknown = set(spec) - {"values", "low", "high", "steps", "log"}
    if unknown:
        raise ConfigError(field, f"unknown key {sorted(unknown)[0]!r} (use values, or low, high, steps, log)")
    if name in LABEL_DIMENSIONS:
        kind = "int"
        param = None
    else:
        param = PARAMETERS_BY_NAME.get(name)
        if param is None:
            raise ConfigError(field, "unknown parameter (any parameter of the schema, groups or team_size)")
        kind = param.kind
        if kind not in ("int", "float", "bool", "choice"):
            raise ConfigError(field, f"{name} is a {kind} parameter: a study varies numeric, boolean or choice "
                                     "parameters only (hold a list or event list fixed in base.params)")
    if "values" in spec:
        if set(spec) - {"values"}:
            raise ConfigError(field, "give either values or a range (low, high), not both")
        values = spec["values"]
        if not isinstance(values, list) or not 1 <= len(values) <= MAX_VALUES:
            raise ConfigError(f"{field}.values", f"must list between 1 and {MAX_VALUES} values")
        checked = tuple(dict.fromkeys(_value(name, kind, param, v, n_parents, n_children, f"{field}.values[{i}]")
                                      for i, v in enumerate(values)))
        return Dimension(name, kind, values=checked)
    if kind in ("choice", "bool"):
        raise ConfigError(field, f"{name} takes values, not a range")
    if "low" not in spec or "high" not in spec:
        raise ConfigError(field, "a range needs low and high")
    integer = kind == "int"
    low = _number(f"{field}.low", spec["low"], integer=integer)
    high = _number(f"{field}.high", spec["high"], integer=integer)
    if not low < high:
        raise ConfigError(field, f"low must be below high (got {low:g} and {high:g})")
    if name in LABEL_DIMENSIONS:
        counted = "n_parents" if name == GROUPS else "n_children"
        raise ConfigError(field, f"{name} takes values (divisors of {counted}), not a range")
    _value(name, kind, param, low, n_parents, n_children, f"{field}.low")
    _value(name, kind, param, high, n_parents, n_children, f"{field}.high")
    log = spec.get("log", False)
    if not isinstance(log, bool):
        raise ConfigError(f"{field}.log", "must be true or false")
    if log and low <= 0:
        raise ConfigError(f"{field}.low", f"must be above 0 for a log range (got {low:g})")
    steps = spec.get("steps")
    if method == "grid":
        if steps is None:
            raise ConfigError(f"{field}.steps", "a grid needs steps for a range (or give values)")
        steps = _count(f"{field}.steps", steps, 2, MAX_STEPS)
    elif steps is not None:
        raise ConfigError(f"{field}.steps", f"{method} draws from the range: steps are for a grid")
    dimension = Dimension(name, kind, low=low if not integer else int(low), high=high if not integer else int(high),
                          steps=steps, log=log)
    if method == "grid":
        for i, v in enumerate(dimension.grid()):
            _value(name, kind, param, v, n_parents, n_children, f"{field}[{i}]")
    return dimension


def _value(name: str, kind: str, param: Any, value: Any, n_parents: Sequence[int], n_children: Sequence[int],
           field: str) -> Any:
    if name in LABEL_DIMENSIONS:
        x = _count(field, value, 1, 1_000_000)
        counted, counts = ("n_parents", n_parents) if name == GROUPS else ("n_children", n_children)
        for count in counts:
            if count % x:
                raise ConfigError(field, f"{x} does not divide {counted} = {count} "
                                         f"(valid: {', '.join(map(str, divisors(count)))})")
        return x
    from mgrao_core.params import _coerce  # the schema's own checks and limits, naming the field

    try:
        return _coerce(param, value)
    except ConfigError as error:
        raise ConfigError(field, error.message) from None


def make_plan(data: Mapping[str, Any]) -> StudyPlan:
    """Validate a study definition (the JSON shape of docs/studies.md).

    Raises:
        ConfigError: naming the field (``space.learning_rate.low``, ``objective.configuration``, ...)
            and the limit. Every trial's experiment is validated too, so a study that is accepted
            runs (``base.*`` or ``space.*`` errors).
    """
    if not isinstance(data, Mapping):
        raise ConfigError("study", "must be an object")
    unknown = set(data) - {"name", "method", "base", "space", "objective", "max_trials", "max_in_flight", "seed"}
    if unknown:
        raise ConfigError(sorted(unknown)[0], "unknown field")
    name = data.get("name", "")
    if not isinstance(name, str) or len(name) > 200:
        raise ConfigError("name", "must be text of at most 200 characters")
    method = data.get("method", "grid")
    if method not in METHODS:
        raise ConfigError("method", f"must be one of {', '.join(METHODS)} (got {method!r})")
    base = data.get("base")
    if not isinstance(base, Mapping):
        raise ConfigError("base", "must be an object: system, algorithms, seeds, episodes, params")
    unknown = set(base) - {"system", "algorithms", "seeds", "first_seed", "episodes", "params", "until"}
    if unknown:
        raise ConfigError(f"base.{sorted(unknown)[0]}", "unknown field")
    systems, variants = _systems(base.get("system", "single"))
    algorithms = base.get("algorithms")
    seeds = base.get("seeds", 10)
    until = None
    if base.get("until") is not None:
        if "seeds" in base:
            raise ConfigError("base.seeds", "give either seeds or until: a rule runs as many seeds as its question "
                                            "needs (until.max_seeds bounds them, from first_seed)")
        for system in systems:
            preset, _ = variants.get(system, (system, {}))
            try:
                until = make_until(base["until"], list(algorithms or PRESETS[preset].algorithms))
            except ConfigError as error:
                raise ConfigError(f"base.{error.field}", error.message) from None
        seeds = until.max_seeds
        base = {"first_seed": 0, **base}  # the rule's seeds start at first_seed (default 0)
    if "first_seed" in base:  # seeds F, F+1, ... (e.g. 10000 on: the calibration seeds)
        first = _count("base.first_seed", base["first_seed"], 0, MAX_SEED_VALUE)
        count = _count("base.seeds", seeds, 1, MAX_SEEDS)
        if first + count - 1 > MAX_SEED_VALUE:
            raise ConfigError("base.first_seed", f"the last seed would pass {MAX_SEED_VALUE}")
        seeds = list(range(first, first + count))
    episodes = _count("base.episodes", base.get("episodes", 100), 1, MAX_EPISODES)
    params = base.get("params", {}) or {}
    if not isinstance(params, Mapping):
        raise ConfigError("base.params", "must be an object of parameter values")

    def spec_of(system: str, seeds: Any, episodes: int) -> ExperimentSpec:
        preset, own = variants.get(system, (system, {}))
        return make_spec(preset, algorithms, seeds, episodes, dict(own) | dict(params))

    for system in systems:  # the base itself must be a valid experiment
        try:
            spec_of(system, seeds, episodes)
        except ConfigError as error:
            named = re.split(r"[\[.]", error.field, maxsplit=1)[0]  # schedule of schedule[2].fraction
            where = "base.params" if named in PARAMETERS_BY_NAME or named in params else "base"
            if system in variants and named not in params and named in variants[system][1]:
                where = f"base.system.{system}.params"
            raise ConfigError(f"{where}.{error.field}", error.message) from None
    seed_list = tuple(spec_of(systems[0], seeds, 1).seeds)
    if len(seed_list) > MAX_SEEDS:
        raise ConfigError("base.seeds", f"at most {MAX_SEEDS}")
    n_parents = [spec_of(s, 1, 1).params.n_parents for s in systems]
    n_children = [spec_of(s, 1, 1).params.n_children for s in systems]
    space = data.get("space")
    if not isinstance(space, Mapping) or not space:
        raise ConfigError("space", "must name at least one parameter to vary")
    if len(space) > MAX_DIMENSIONS:
        raise ConfigError("space", f"at most {MAX_DIMENSIONS} dimensions (got {len(space)})")
    dimensions = tuple(_dimension(k, v, method, n_parents, n_children) for k, v in space.items())
    objective = _objective(data.get("objective"), systems, dimensions, algorithms, variants)
    max_trials = _count("max_trials", data.get("max_trials", 100), 1, MAX_TRIALS)
    max_in_flight = _count("max_in_flight", data.get("max_in_flight", 4), 1, MAX_IN_FLIGHT)
    seed = _count("seed", data.get("seed", 0), 0, 2**32 - 1)
    plan = StudyPlan(name, method, systems, tuple(algorithms) if algorithms is not None else None, seed_list,
                     episodes, dict(params), dimensions, objective, max_trials, max_in_flight, seed,
                     variants=variants, until=until)
    if method == "grid":
        size = math.prod(len(d.grid()) for d in dimensions)
        if size > MAX_TRIALS:
            raise ConfigError("space", f"the grid has {size:,} cells, over the limit of {MAX_TRIALS:,} trials")
        if size > max_trials:
            raise ConfigError("max_trials", f"the grid has {size:,} cells: max_trials must be at least that "
                                            f"(got {max_trials:,})")
        for index in _corners(plan):  # every cell is validated when its trial is made; the corners now
            _check_trial(plan, plan.cell(index))
    else:
        for params in _range_corners(plan):
            _check_trial(plan, params)
    return plan


def _systems(value: Any) -> tuple[tuple[str, ...], dict[str, tuple[str, dict[str, Any]]]]:
    """``base.system``: a preset, or a list of distinct systems, each a preset or a named system.

    A named system is ``{"name", "system", "params"}``: a preset and its overrides under a name of its own
    (what the service makes of a saved system's name in a list). Returns the names and the named systems.
    """
    items = value if isinstance(value, list) else [value]
    message = f"must be one of {', '.join(PRESETS)} or a list of distinct ones (presets or saved systems)"
    if not items:
        raise ConfigError("base.system", message)
    names, variants = [], {}
    for i, item in enumerate(items):
        if isinstance(item, Mapping) and isinstance(value, list):
            unknown = set(item) - {"name", "system", "params"}
            if unknown:
                raise ConfigError(f"base.system[{i}].{sorted(unknown)[0]}", "unknown field")
            name, preset, own = item.get("name"), item.get("system"), item.get("params", {}) or {}
            if not isinstance(name, str) or not name or len(name) > 64 or name in PRESETS:
                raise ConfigError(f"base.system[{i}].name", "must be a name of 1 to 64 characters that is no preset's")
            if preset not in PRESETS:
                raise ConfigError(f"base.system[{i}].system", f"must be one of {', '.join(PRESETS)}")
            if not isinstance(own, Mapping):
                raise ConfigError(f"base.system[{i}].params", "must be an object of parameter values")
            variants[name] = (preset, dict(own))
            names.append(name)
        elif isinstance(item, str) and item in PRESETS:
            names.append(item)
        else:
            raise ConfigError("base.system", message)
    if len(set(names)) != len(names):
        raise ConfigError("base.system", message)
    return tuple(names), variants


def _objective(data: Any, systems: tuple[str, ...], dimensions: tuple[Dimension, ...],
               algorithms: Sequence[str] | None,
               variants: Mapping[str, tuple[str, Mapping[str, Any]]] | None = None) -> Objective:
    if not isinstance(data, Mapping):
        raise ConfigError("objective", "must be an object: configuration, metric, direction")
    unknown = set(data) - {"configuration", "metric", "direction", "system"}
    if unknown:
        raise ConfigError(f"objective.{sorted(unknown)[0]}", "unknown field")
    metric = data.get("metric")
    if metric not in METRICS:
        raise ConfigError("objective.metric", f"must be one of {', '.join(METRICS)} (got {metric!r})")
    direction = data.get("direction", "minimize" if metric == "paper_deviation" else "maximize")
    if direction not in DIRECTIONS:
        raise ConfigError("objective.direction", f"must be maximize or minimize (got {direction!r})")
    system = data.get("system")
    if metric == "paper_deviation":
        missing = [s for s in systems if s in (variants or {}) or not PRESETS[s].paper_pct_from_uniform]
        if missing:
            raise ConfigError("base.system", f"{missing[0]} has no figures in the paper")
        return Objective(metric, direction, None, None)
    configuration = data.get("configuration")
    if not isinstance(configuration, str):
        raise ConfigError("objective.configuration", "must name one of the study's configurations")
    if len(systems) > 1 and system not in systems:
        raise ConfigError("objective.system", f"the base runs {', '.join(systems)}: name the one to read")
    if system is not None and system not in systems:
        raise ConfigError("objective.system", f"must be one of the base's systems ({', '.join(systems)})")
    target = system or systems[0]
    labels = list(algorithms or PRESETS[(variants or {}).get(target, (target,))[0]].algorithms)
    swept = {d.name for d in dimensions}
    if configuration == GROUP_LABEL:
        if GROUPS not in swept:
            raise ConfigError("objective.configuration", f"{GROUP_LABEL} needs a groups dimension in the space")
        if TEAM in swept:
            raise ConfigError("objective.configuration", f"with a team_size dimension the configuration the space "
                                                         f"adds is {TEAM_LABEL}")
    elif configuration == TEAM_LABEL:
        if not swept & set(LABEL_DIMENSIONS):
            raise ConfigError("objective.configuration", f"{TEAM_LABEL} needs a groups or team_size dimension in "
                                                         "the space")
    elif configuration not in labels:
        raise ConfigError("objective.configuration",
                          f"{configuration!r} is not among the study's configurations ({', '.join(labels)})")
    if metric in ("pct_from_uniform", "pct_of_max") and "uniform" not in labels:
        raise ConfigError("objective.metric", f"{metric} needs uniform among the configurations")
    if metric == "pct_of_max" and "mgrao-max" not in labels:
        raise ConfigError("objective.metric", "pct_of_max needs mgrao-max among the configurations")
    return Objective(metric, direction, configuration, system)


def _corners(plan: StudyPlan) -> list[int]:
    sizes = [len(d.grid()) for d in plan.dimensions]
    strides = _strides(sizes)
    return sorted({sum(c * s for c, s in zip(choice, strides, strict=True))
                   for choice in itertools.product(*[(0, n - 1) for n in sizes])})[:256]


def _range_corners(plan: StudyPlan) -> list[dict[str, Any]]:
    ends = [(d.values[0], d.values[-1]) if d.values else (d.low, d.high) for d in plan.dimensions]
    names = [d.name for d in plan.dimensions]
    return [dict(zip(names, choice, strict=True)) for choice in itertools.product(*ends)][:256]


def _check_trial(plan: StudyPlan, params: Mapping[str, Any]) -> None:
    """Raise a ConfigError naming ``space`` where a trial of ``params`` is no valid experiment, in the fields' words.

    "a trial with n_parents = 15 is not a valid experiment: mgrao-25:1: x must be a divisor of n_parents = 15":
    a refused configuration's message names its label (not its place in a list); a parameter's, the parameter.
    """
    trial = ", ".join(f"{name} = {value}" for name, value in params.items())
    for system in plan.systems:
        try:
            plan._spec(system, params)
        except ConfigError as error:
            what = error.message if error.field.split("[")[0] in ("algorithms", "base.algorithms") \
                else f"{error.field.removeprefix('base.').removeprefix('params.')}: {error.message}"
            on = f" of {system}" if len(plan.systems) > 1 else ""
            raise ConfigError("space", f"a trial{on} with {trial} is not a valid experiment: {what}") from None
