"""Every parameter of the simulated system and of MG-RAO, with defaults, limits and help.

The defaults are those of ``docs/model.md``; the presets in :mod:`mgrao_core.presets`
override a few of them per system. :data:`PARAMETERS` is the single schema that validation,
the command line, the REST API and the dashboard's form all read.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from collections.abc import Mapping
from typing import Any

from mgrao_core import quality
from mgrao_core.algorithms import FAMILIES
from mgrao_core.errors import ConfigError, raise_all
from mgrao_core.parameter import Parameter, Record

QUALITY_MODELS = tuple(quality.QUALITY_MODELS)
ROUTINGS = ("per-composite", "per-task")
ABSENT_TASKS = ("excluded", "counted")
FREQUENCY_PROFILES = ("constant", "two-speed", "explicit")
CHANGES = ("new-profiles", "new-composites", "frequencies")
"""What a scheduled event changes (docs/model.md, "Changes over time")."""
LAST_EPISODE = 99_999
"""The last episode an event may name: :data:`mgrao_core.spec.MAX_EPISODES` - 1 (spec imports this module)."""
MAX_PERIOD = 1000
MAX_RESOURCES = 8
RESOURCE_COMBINATIONS = ("scarcest", "weighted")
RESOURCE_CREDITS = ("shared", "by-share")
HIERARCHIES = ("none", "borrow", "hand-over")
TOPOLOGIES = ("complete", "ring", "random")
"""Which children each parent offers its tasks to (docs/model.md, "Sparse worlds")."""
MAX_AGENTS = 1_000_000
"""The most parents, and the most children, a system may declare; what a job may hold is bounded by its bytes
(:mod:`mgrao_core.budget`), checked before it runs."""
MAX_CHILDREN_PER_PARENT = 10_000
NEIGHBOURHOODS = ("all", "ring")


_ENVIRONMENT: tuple[Parameter, ...] = (
    # The system (paper section 3, appendix "General parameter values").
    Parameter("n_types", "int", 20, "Number of atomic task types.", "system", 2, 200, identity="always"),
    Parameter("n_composite_types", "int", 10, "Number of composite task types.", "system", 1, 1000, identity="always"),
    Parameter(
        "types_per_composite", "int", 5,
        "Distinct atomic types in each composite type (at most n_types).", "system", 1, 200, identity="always",
    ),
    Parameter("n_parents", "int", 10, "Number of parent agents (what a job may hold is bounded by its memory).",
              "system", 1, MAX_AGENTS, identity="always"),
    Parameter("n_children", "int", 1, "Number of child agents (what a job may hold is bounded by its memory).",
              "system", 1, MAX_AGENTS, identity="always"),
    Parameter(
        "resource_mean", "float", 0.5,
        "Mean of each child's resource amount, Normal(mean, sd) clipped into (0, 1].",
        "system", 0.001, 1.0, identity="always",
    ),
    Parameter("resource_sd", "float", 0.2, "Standard deviation of each child's resource amount.",
              "system", 0.0, 1.0, identity="always"),
    # Values and quality: docs/model.md ("Value of atomic tasks", "Quality").
    Parameter(
        "value_concentration", "float", 1.0,
        "Dirichlet concentration of each parent's fixed value profile.",
        "values", 0.01, 100.0, identity="always",
    ),
    Parameter(
        "value_noise", "float", 0.1,
        "Log-normal noise on each task instance's proportional values.", "values", 0.0, 5.0, identity="always",
    ),
    # Quality of an atomic task: docs/model.md ("Quality", "Environment readings").
    Parameter(
        "quality_model", "choice", "hyperbolic",
        "Atomic task quality from the resource x = w[type] * ar given to the type: hyperbolic x/(x+h), "
        "exponential 1-exp(-x/h), or relative-linear min(1, quality_at_uniform * n_types * w[type]).",
        "quality", choices=QUALITY_MODELS, identity="always",
    ),
    Parameter(
        "half_saturation", "float", 0.2,
        "h: the resource at which hyperbolic quality is 1/2 (exponential: 1-1/e); unused by relative-linear.",
        "quality", 0.001, 10.0, identity="always",
    ),
    Parameter(
        "load_sharing", "bool", False,
        "Divide a type's resource among the instances of that type the child receives in the episode.",
        "quality", identity="always",
    ),
    Parameter(
        "quality_at_uniform", "float", 0.3,
        "relative-linear only: atomic task quality when a type gets exactly the uniform share.",
        "quality", 0.001, 1.0, identity="always",
    ),
    Parameter(
        "quality_floor", "float", 1e-6,
        "Smallest atomic task quality, so that quality stays in (0, 1].",
        "quality", 1e-12, 0.1, identity="always",
    ),
)
_ALLOCATION: tuple[Parameter, ...] = (
    # Multi-child task allocation by parents.
    Parameter(
        "routing", "choice", "per-composite",
        "With several children: a parent gives its whole composite task to one child chosen by the "
        "composite quality it got back (per-composite), or chooses a child for each atomic task by the "
        "value it got back for that type (per-task).",
        "allocation", choices=ROUTINGS, identity="always",
    ),
    Parameter(
        "topology", "choice", "complete",
        "Which children each parent offers its tasks to: every child (complete, the paper's), the "
        "children_per_parent nearest to it when parents and children are spread evenly on one ring (ring), or "
        "children_per_parent drawn at random with the seed (random). A sparse world's cost and memory grow with "
        "its links, not with children x parents.",
        "allocation", choices=TOPOLOGIES, identity="when-set",
    ),
    Parameter(
        "children_per_parent", "int", 8,
        "Under topology ring or random: how many children each parent offers its tasks to (at most n_children).",
        "allocation", 1, MAX_CHILDREN_PER_PARENT, identity="when-set",
    ),
    Parameter(
        "epsilon", "float", 0.1,
        "Probability that a parent chooses a non-greedy child.", "allocation", 0.0, 1.0, identity="always",
    ),
    Parameter(
        "boltzmann_temperature", "float", 0.1,
        "Temperature of the Boltzmann choice among the non-greedy children.",
        "allocation", 1e-4, 100.0, identity="always",
    ),
    Parameter(
        "initial_estimate", "float", 1.0,
        "Value a parent assumes for a child it has not tried yet (optimistic start).",
        "allocation", 0.0, 10.0, identity="always",
    ),
    Parameter(
        "tie_break", "choice", "random",
        "How a parent breaks ties between equally good children.", "allocation",
        choices=("random", "first"), identity="always",
    ),
    # Volatility (the volatile system).
    Parameter(
        "leave_probability", "float", 0.0,
        "Probability per episode that an active parent leaves.", "volatility", 0.0, 1.0, identity="always",
    ),
    Parameter(
        "join_probability", "float", 0.0,
        "Probability per episode that an absent parent rejoins.", "volatility", 0.0, 1.0, identity="always",
    ),
    Parameter(
        "rejoin_profile", "choice", "same",
        "Whether a rejoining parent keeps its value profile or brings a newly drawn one.",
        "volatility", choices=("same", "new"), identity="always",
    ),
    Parameter(
        "absent_tasks", "choice", "excluded",
        "An absent parent's composite task: not received at all (excluded), or counted in system "
        "utility at absent_quality without involving any child (counted).",
        "volatility", choices=ABSENT_TASKS, identity="always",
    ),
    Parameter(
        "absent_quality", "float", None,
        "Composite quality of an absent parent's task under absent_tasks=counted; empty means the "
        "quality of a uniform allocation at resource_mean.",
        "volatility", 0.0, 1.0, nullable=True, identity="always",
    ),
)

_EVENT_FIELDS: tuple[Parameter, ...] = (
    Parameter("episode", "int", None, "The episode at whose start the event applies (0: before the first).",
              "dynamics", 0, LAST_EPISODE),
    Parameter("change", "choice", None,
              "new-profiles: the parents chosen draw new value profiles; new-composites: they draw new composite "
              "types; frequencies: the composite types chosen arrive every `period` episodes from now.",
              "dynamics", choices=CHANGES),
    Parameter("fraction", "float", 1.0,
              "Share of the parents (of the composite types, for frequencies) the event changes, chosen per seed.",
              "dynamics", 0.0, 1.0),
    Parameter("period", "int", 1, "frequencies only: the new period of the composite types chosen.",
              "dynamics", 1, MAX_PERIOD),
)
_DYNAMICS: tuple[Parameter, ...] = (
    # Task frequencies, changes over time, unpredictable parents, capability: docs/model.md.
    Parameter(
        "frequency_profile", "choice", "constant",
        "How often each composite type arrives: every episode (constant), half the types every episode and "
        "half every slow_period episodes (two-speed), or every composite_periods[k] episodes (explicit).",
        "dynamics", choices=FREQUENCY_PROFILES,
    ),
    Parameter("slow_period", "int", 4, "two-speed only: episodes between arrivals of the slow composite types.",
              "dynamics", 1, MAX_PERIOD),
    Parameter(
        "composite_periods", "list", (),
        "explicit only: episodes between arrivals of each composite type, one per composite type.",
        "dynamics", 1, MAX_PERIOD, item_kind="int", min_items=0, max_items=1000,
    ),
    Parameter(
        "schedule", "events", (),
        "Changes over time: events applied at the start of given episodes, each to a share of the parents "
        "(or composite types) chosen per seed.",
        "dynamics", min_items=0, max_items=100, fields=_EVENT_FIELDS,
    ),
    Parameter(
        "unpredictable_fraction", "float", 0.0,
        "Share of the parents (chosen per seed) that draw their composite type, value profile and arrival anew "
        "every episode.",
        "dynamics", 0.0, 1.0,
    ),
    Parameter(
        "capability_spread", "float", 0.0,
        "Log-normal spread of each child's half-saturation per atomic type (h * exp(spread * N(0, 1)), drawn "
        "per child and type); 0: every child alike.",
        "system", 0.0, 3.0,
    ),
)
_RESOURCES: tuple[Parameter, ...] = (
    # Several resources (issue 20, point 1): docs/model.md ("Several resources").
    Parameter(
        "n_resources", "int", 1,
        "Resources each child owns, each drawn like the first (Normal(resource_mean, resource_sd) clipped into "
        "(0, 1]); 1 is the paper's experiments.",
        "resources", 1, MAX_RESOURCES,
    ),
    Parameter(
        "need_concentration", "float", 1.0,
        "Dirichlet concentration of each atomic type's needs of the resources (drawn per seed; unused with one "
        "resource).",
        "resources", 0.01, 100.0,
    ),
    Parameter(
        "resource_combination", "choice", "scarcest",
        "How several resources make one atomic task's quality: the scarcest relative to the type's need decides "
        "(scarcest), or a need-weighted geometric mean of the resources relative to their needs (weighted).",
        "resources", choices=RESOURCE_COMBINATIONS,
    ),
    Parameter(
        "resource_credit", "choice", "shared",
        "MG-RAO with several resources: every resource's PW learns the whole returned value (shared, the paper "
        "literally) or its share of it, the resource's output elasticity in the combination (by-share).",
        "resources", choices=RESOURCE_CREDITS,
    ),
)

_LEARNING: tuple[Parameter, ...] = (
    # The cost of learning (the paper's future work): docs/model.md ("The cost of learning").
    Parameter(
        "learning_cost", "float", 0.0,
        "Share of a child's resources that learning one model per parent (mgrao-max) takes from its tasks; a "
        "learner keeping fewer numbers pays in proportion, uniform and the oracle nothing; 0 is the paper's "
        "experiments.",
        "learning", 0.0, 1.0,
    ),
)

_HIERARCHY: tuple[Parameter, ...] = (
    # Tasks that fail and hierarchical resource allocation (the paper's future work): docs/model.md ("Tasks that
    # fail, and hierarchical allocation").
    Parameter(
        "task_need", "float", 0.0,
        "Amount of its child's resource an atomic task needs (with several resources, of the last one), in units "
        "of the mean child's uniform amount (resource_mean / n_types); below it the task fails, its value lost; 0: "
        "no task fails (the paper's experiments).",
        "hierarchy", 0.0, 10.0,
    ),
    Parameter(
        "hierarchy", "choice", "none",
        "What a child does with a task it cannot complete: return the failure (none), borrow the shortfall from a "
        "neighbour whose own tasks of that type keep their need (borrow, the lender's loss), or hand the task "
        "over to a neighbour that meets the need (hand-over, its quality discounted by handover_cost).",
        "hierarchy", choices=HIERARCHIES,
    ),
    Parameter(
        "neighbours", "choice", "all",
        "Which children a child can turn to, in the order it asks them: every other child, from the next one on "
        "(all), or the next and the previous one (ring).",
        "hierarchy", choices=NEIGHBOURHOODS,
    ),
    Parameter(
        "handover_cost", "float", 0.5,
        "Share of a handed-over task's quality lost to the hand-over's delay (hierarchy = hand-over).",
        "hierarchy", 0.0, 1.0,
    ),
)

PARAMETERS: tuple[Parameter, ...] = (
    *_ENVIRONMENT, *(p for f in FAMILIES for p in f.parameters), *_ALLOCATION, *_DYNAMICS, *_RESOURCES, *_LEARNING,
    *_HIERARCHY,
)
"""Every parameter: the system's, values' and quality's, then each algorithm family's own (MG-RAO's
``learning_rate``, ``trace_decay``, ``temperature``, declared in :mod:`mgrao_core.algorithms.mgrao`), then
the parents' allocation and volatility, then the system's dynamics (frequencies, schedule, unpredictable
parents, capability), then several resources (``n_resources`` and how they combine), then the cost of
learning, then tasks that fail and the hierarchy that completes them."""
PARAMETERS_BY_NAME: dict[str, Parameter] = {p.name: p for p in PARAMETERS}
GROUP_TITLES: dict[str, str] = {
    "system": "System", "values": "Values", "quality": "Quality (environment)",
    "allocation": "Allocation (environment)", "volatility": "Volatility (environment)",
    "dynamics": "Dynamics (environment)", "resources": "Resources (environment)",
    "learning": "Learning cost", "hierarchy": "Failures and hierarchy",
    **{f.name: f"{f.title} (algorithm)" for f in FAMILIES if f.parameters},
}
"""Each parameter group's heading in forms and tables: the model's parts, then each family's (its title)."""


class _Derived:
    """What a parameter set computes from its fields (the base of :class:`SystemParams`)."""

    @property
    def effective_temperature(self) -> float:
        """The softmax temperature in use: ``temperature`` or, when unset, ``1 / n_types``."""
        return self.temperature if self.temperature is not None else 1.0 / self.n_types

    @property
    def sparse(self) -> bool:
        """Whether each parent offers its tasks to some children only (``topology`` other than complete)."""
        return self.topology != "complete"

    @property
    def children_offered(self) -> int:
        """How many children each parent chooses among: ``children_per_parent`` in a sparse world, else all."""
        return self.children_per_parent if self.sparse else self.n_children

    @property
    def tasks_can_fail(self) -> bool:
        """Whether an atomic task can fail (``task_need > 0``): where the engine resolves and counts failures."""
        return self.task_need > 0

    @property
    def effective_absent_quality(self) -> float:
        """The quality an absent parent's task counts at under ``absent_tasks="counted"``.

        ``absent_quality``, or when unset the quality of a uniform allocation at the mean resource
        under the quality model.
        """
        if self.absent_quality is not None:
            return self.absent_quality
        return float(quality.atomic_quality(1.0 / self.n_types, self.resource_mean, self))

    def as_dict(self) -> dict[str, Any]:
        """All parameters as plain JSON-ready data (a list's or event list's value as a JSON list)."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}

    def as_config(self) -> dict[str, Any]:
        """The parameters that make a configuration's identity: what a job stores and ``config_hash`` hashes.

        Every ``identity="always"`` parameter, and each ``"when-set"`` one only when it differs from its
        default (:func:`identity_params`).
        """
        return identity_params(self.as_dict())


def _plain(value: Any) -> Any:
    """A parameter's value as plain JSON data: tuples (a list, an event list) as lists, events as objects."""
    if isinstance(value, Record):
        return value.as_dict()
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    return value


def identity_params(values: Mapping[str, Any], parameters: tuple[Parameter, ...] | None = None) -> dict[str, Any]:
    """``values`` without the ``identity="when-set"`` parameters that are at their default.

    Adding a parameter thus leaves the stored ``params`` and the ``config_hash`` of every configuration
    that keeps it at its default as they were (docs/model.md, "Adding a parameter").
    """
    schema = {p.name: p for p in (PARAMETERS if parameters is None else parameters)}
    return {k: v for k, v in values.items()
            if k not in schema or schema[k].identity == "always" or _plain(v) != _plain(schema[k].default)}


def complete_params(stored: Mapping[str, Any], parameters: tuple[Parameter, ...] | None = None) -> dict[str, Any]:
    """A stored configuration's ``params`` with each absent ``"when-set"`` parameter at its default.

    The inverse of :func:`identity_params` (an absent parameter means its schema default, not a preset's).
    """
    schema = PARAMETERS if parameters is None else parameters
    return {p.name: _plain(p.default) for p in schema if p.identity == "when-set"} | dict(stored)


_TYPES = {"int": int, "float": float, "bool": bool, "choice": str, "list": tuple, "events": tuple}


def _field(param: Parameter) -> tuple[str, Any, Any]:
    kind = _TYPES[param.kind]
    return param.name, kind | None if param.nullable else kind, dataclasses.field(default=param.default)


def system_params_class(parameters: tuple[Parameter, ...]) -> type:
    """The class of complete parameter sets of ``parameters`` (:class:`SystemParams` is that of :data:`PARAMETERS`)."""
    made = dataclasses.make_dataclass("SystemParams", [_field(p) for p in parameters], bases=(_Derived,), frozen=True)
    made.__module__ = __name__  # where pickle finds it (make_dataclass takes no module before Python 3.12)
    made.__doc__ = """A complete, validated parameter set (build it with :func:`make_params`).

One field per entry of :data:`PARAMETERS`, in its order, defaulting to the entry's default (so a family's
parameters are fields without an edit here), and the derived values of :class:`_Derived`."""
    return made


SystemParams = system_params_class(PARAMETERS)


NUMBER_TEXT = r"^[ \t\n\r]*[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?[ \t\n\r]*$"
"""A number written as text (the command line's ``--set``, or a string in JSON): plain decimal or exponent notation
in ASCII digits (``12``, ``-0.25``, ``.5``, ``1e-3``), blanks around it ignored; a JSON Schema pattern as well."""
_NUMBER_TEXT = re.compile(NUMBER_TEXT)
_NOT_FINITE = ("inf", "infinity", "nan")


def number_from_text(field: str, text: str) -> float:
    """The number ``text`` writes, by the one rule for numbers given as text (:data:`NUMBER_TEXT`).

    Python's ``float()`` reads more: ``"1_0"`` as 10, an Arabic-Indic or full-width ``"\u0663"`` as 3, ``"inf"``;
    none of them is a number a person or a JSON client means to send, so each is refused.

    Args:
        field: what the text is the value of, named by the error.
        text: the text.

    Returns:
        The number, as a float (possibly not finite: ``"1e400"``; the caller checks its own limits).

    Raises:
        ConfigError: the text is not plain decimal or exponent notation.
    """
    if _NUMBER_TEXT.match(text):
        return float(text)
    if text.strip(" \t\n\r").lower().lstrip("+-") in _NOT_FINITE:
        raise ConfigError(field, f"must be a finite number (got {text!r})")
    raise ConfigError(field, f"must be a number in plain decimal or exponent notation, such as 12, 0.25 or 1e-3 "
                             f"(got {text[:60]!r})")


_TRUE = ("true", "on", "yes", "1")
_FALSE = ("false", "off", "no", "0")


def _boolean(param: Parameter, value: Any) -> bool:
    if isinstance(value, bool):
        return value
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    if isinstance(value, str) and value.strip().lower() in _TRUE + _FALSE:
        return value.strip().lower() in _TRUE
    raise ConfigError(param.name, f"must be true or false (got {value!r})")


def _json_list(param: Parameter, value: str, allow_commas: bool) -> Any:
    text = value.strip()
    if allow_commas and not text.startswith("["):
        return [item.strip() for item in text.split(",")] if text else []
    try:
        return json.loads(text)
    except ValueError:
        raise ConfigError(param.name, f"must be a JSON list (got {value[:60]!r})") from None


def _items(param: Parameter, value: Any) -> list[Any]:
    """A list or event list's items, from a sequence or (a command line's) text; checks their count."""
    if isinstance(value, str):
        value = _json_list(param, value, allow_commas=param.kind == "list")
    if not isinstance(value, list | tuple):
        raise ConfigError(param.name, f"must be a list (got {type(value).__name__})")
    if param.min_items is not None and len(value) < param.min_items:
        raise ConfigError(param.name, f"must have at least {param.min_items} items (got {len(value)})")
    if param.max_items is not None and len(value) > param.max_items:
        raise ConfigError(param.name, f"must have at most {param.max_items} items (got {len(value)})")
    return list(value)


def _record(param: Parameter, index: int, value: Any) -> Record:
    where = f"{param.name}[{index}]"
    if isinstance(value, Record):
        value = value.as_dict()
    if not isinstance(value, Mapping):
        raise ConfigError(where, f"must be an object with fields {', '.join(f.name for f in param.fields)} "
                                 f"(got {type(value).__name__})")
    known = [f.name for f in param.fields]
    for key in value:
        if key not in known:
            raise ConfigError(f"{where}.{key}", f"unknown field (fields: {', '.join(known)})")
    fields = {}
    for field in param.fields:
        nested = dataclasses.replace(field, name=f"{where}.{field.name}")
        if field.name in value:
            fields[field.name] = _coerce(nested, value[field.name])
        elif field.default is None and not field.nullable:
            raise ConfigError(nested.name, "is required")
        else:
            fields[field.name] = field.default
    return Record.of(fields)


def _coerce(param: Parameter, value: Any) -> Any:
    if param.kind == "list":
        return tuple(_coerce(dataclasses.replace(param.item, name=f"{param.name}[{i}]"), item)
                     for i, item in enumerate(_items(param, value)))
    if param.kind == "events":
        return tuple(_record(param, i, item) for i, item in enumerate(_items(param, value)))
    if param.nullable and isinstance(value, str) and value.strip() in ("", "none", "null"):
        value = None
    if value is None:
        if param.nullable:
            return None
        raise ConfigError(param.name, "must not be empty")
    if param.kind == "bool":
        return _boolean(param, value)
    if param.kind == "choice":
        if value not in param.choices:
            raise ConfigError(param.name, f"must be one of {', '.join(param.choices)} (got {value!r})")
        return value
    if isinstance(value, bool) or not isinstance(value, int | float):
        if isinstance(value, str):
            value = number_from_text(param.name, value)
        else:
            raise ConfigError(param.name, f"must be a number (got {type(value).__name__})")
    if param.kind == "int":
        if isinstance(value, float) and not value.is_integer():
            raise ConfigError(param.name, f"must be a whole number (got {value})")
        value = int(value)
    else:
        try:
            value = float(value) + 0.0  # + 0.0: -0.0 is 0.0
        except OverflowError:  # an integer of hundreds of digits
            raise ConfigError(param.name, "must be a finite number (got a number too large)") from None
        if not math.isfinite(value):
            raise ConfigError(param.name, "must be a finite number")
    low_ok = value > param.minimum if param.exclusive_minimum else value >= param.minimum
    if not low_ok or value > param.maximum:
        low = "(" if param.exclusive_minimum else "["

        def number(x: float) -> str:  # a whole number's every digit (1000000, not 1e+06)
            return str(int(x)) if param.kind == "int" and abs(x) < 1e15 else f"{x:g}"

        shown = number(value) if abs(value) < 1e15 else "a number too large"
        limits = f"{low}{number(param.minimum)}, {number(param.maximum)}]"
        raise ConfigError(param.name, f"must be in {limits} (got {shown})")
    return value




def make_params(overrides: Mapping[str, Any] | None = None, base: SystemParams | None = None) -> SystemParams:
    """Validate ``overrides`` on top of ``base`` (the defaults of docs/model.md when omitted).

    Args:
        overrides: parameter names to values; values may be strings from a command line.
        base: the parameter set to start from, e.g. a preset's.

    Returns:
        A new, fully validated :class:`SystemParams`.

    Raises:
        ConfigError: an unknown name, a wrong type, a value outside its limits (a list's item or an event's
            field named as ``composite_periods[3]`` or ``schedule[2].fraction``), ``types_per_composite``
            larger than ``n_types``, or ``composite_periods`` not one per composite type under
            ``frequency_profile="explicit"``. Every parameter refused by its own rule is named at once
            (:class:`~mgrao_core.errors.ConfigErrors`); the rules between parameters are checked when each is valid.
    """
    base = base or SystemParams()
    values = {f.name: getattr(base, f.name) for f in dataclasses.fields(base)}
    errors: list[ConfigError] = []
    for name, value in (overrides or {}).items():
        param = PARAMETERS_BY_NAME.get(name)
        try:
            if param is None:
                raise ConfigError(name, "unknown parameter (see the parameter schema for valid names)")
            values[name] = _coerce(param, value)
        except ConfigError as error:
            errors.append(error)
    raise_all(errors)
    if values["types_per_composite"] > values["n_types"]:
        raise ConfigError(
            "types_per_composite",
            f"must be at most n_types = {values['n_types']} (got {values['types_per_composite']})",
        )
    if values["topology"] != "complete" and values["children_per_parent"] > values["n_children"]:
        raise ConfigError(
            "children_per_parent",
            f"must be at most n_children = {values['n_children']} under topology={values['topology']} "
            f"(got {values['children_per_parent']})",
        )
    if values["frequency_profile"] == "explicit" and len(values["composite_periods"]) != values["n_composite_types"]:
        raise ConfigError(
            "composite_periods",
            f"must have n_composite_types = {values['n_composite_types']} items under frequency_profile=explicit "
            f"(got {len(values['composite_periods'])})",
        )
    return SystemParams(**values)
