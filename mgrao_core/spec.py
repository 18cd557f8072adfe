"""What to run: a validated experiment specification, and the documented work limits."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from mgrao_core.algorithms import Algorithm, parse_algorithms, task_share, valid_labels
from mgrao_core.budget import MAX_CHUNK_BYTES, MAX_RESULT_BYTES, chunk_cost, result_bytes
from mgrao_core.errors import ConfigError, WorkLimitError, raise_all
from mgrao_core.params import SystemParams, complete_params, make_params
from mgrao_core.presets import get_preset

MAX_SEEDS = 1000
MAX_SEED_VALUE = 2**32 - 1
MAX_EPISODES = 100_000
MAX_ALGORITHMS = 20
MAX_WORK = 2_000_000_000
"""Atomic tasks per experiment: seeds x algorithms x episodes x parents x types per composite."""
WORK_FACTORS = ("seeds", "algorithms", "episodes", "n_parents", "types_per_composite")
"""What :attr:`ExperimentSpec.work` multiplies: the counts of seeds and algorithms, the episodes, and two parameters."""
MAX_GROUP_UPDATES = 40_000_000_000
"""Row updates of algorithm 1 per experiment, counted at their worst: each returned value
renormalises every active parent-group row of its child, and at slow trace decays every row stays
active, so an MG-RAO run costs up to atomic tasks x groups (about 3 ns each here)."""


@dataclass(frozen=True)
class ExperimentSpec:
    """A complete, validated experiment (build it with :func:`make_spec`).

    Attributes:
        system: the preset it starts from (single, multi, volatile, large).
        params: the full parameter set (preset plus overrides).
        algorithms: algorithm labels, in the order given.
        seeds: the seeds, one run per (algorithm, seed).
        episodes: episodes per run.
    """

    system: str
    params: SystemParams
    algorithms: tuple[str, ...]
    seeds: tuple[int, ...]
    episodes: int

    @property
    def parsed_algorithms(self) -> tuple[Algorithm, ...]:
        """The algorithms, parsed for this system's numbers of parents and children."""
        return parse_algorithms(self.algorithms, self.params.n_parents, self.params.n_children)

    @property
    def work(self) -> int:
        """Atomic tasks the experiment simulates (what :data:`MAX_WORK` bounds)."""
        p = self.params
        return len(self.seeds) * len(self.algorithms) * self.episodes * p.n_parents * p.types_per_composite

    @property
    def group_updates(self) -> int:
        """Row updates the experiment needs at their worst (what :data:`MAX_GROUP_UPDATES` bounds).

        Algorithm 1's: each returned value renormalises every active row of its child. And what grows with the
        children rather than the tasks: mgrao-adaptive's statistics visit every child for each composite that comes
        back, and a failing task under a hierarchy of every neighbour (``neighbours = all``) may ask every other child.
        """
        p = self.params
        per_run = self.episodes * p.n_parents * p.types_per_composite
        # MG-RAO keeps a PW per resource (docs/model.md, "Several resources"): each value updates every one
        per_resource = {"mgrao": p.n_resources}
        updates = per_run * sum(a.n_groups * per_resource.get(a.kind, 1) for a in self.parsed_algorithms)
        adaptive = sum(a.kind == "mgrao-adaptive" for a in self.parsed_algorithms)
        updates += adaptive * self.episodes * p.n_parents * p.n_children
        if p.tasks_can_fail and p.hierarchy != "none" and p.neighbours == "all":
            updates += len(self.algorithms) * per_run * (p.n_children - 1)
        return len(self.seeds) * updates

    def as_dict(self) -> dict[str, Any]:
        """The specification as JSON-ready data (round-trips through :func:`spec_from_dict`).

        ``params`` is :meth:`SystemParams.as_config`: a parameter added since issue 20 is named only when it is
        away from its default, so that a job's ``config_hash`` does not change when parameters are added.
        """
        return {
            "system": self.system,
            "params": self.params.as_config(),
            "algorithms": list(self.algorithms),
            "seeds": list(self.seeds),
            "episodes": self.episodes,
        }


T = TypeVar("T")

def _count(field: str, value: Any, maximum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(field, f"must be a whole number (got {value!r})")
    if not 1 <= value <= maximum:
        raise ConfigError(field, f"must be between 1 and {maximum} (got {value})")
    return value


def _seeds(value: int | Sequence[int]) -> tuple[int, ...]:
    if isinstance(value, int) and not isinstance(value, bool):
        return tuple(range(_count("seeds", value, MAX_SEEDS)))
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ConfigError("seeds", "must be a count or a list of seeds")
    if not 1 <= len(value) <= MAX_SEEDS:
        raise ConfigError("seeds", f"must list between 1 and {MAX_SEEDS} seeds (got {len(value)})")
    for i, seed in enumerate(value):
        if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED_VALUE:
            raise ConfigError(f"seeds[{i}]", f"must be a whole number in [0, {MAX_SEED_VALUE}] (got {seed!r})")
    if len(set(value)) != len(value):
        raise ConfigError("seeds", "must not repeat a seed")
    return tuple(value)


def make_spec(
    system: str,
    algorithms: Sequence[str] | None = None,
    seeds: int | Sequence[int] = 30,
    episodes: int = 100,
    overrides: Mapping[str, Any] | None = None,
    memory_budget: int = MAX_CHUNK_BYTES,
) -> ExperimentSpec:
    """Validate an experiment.

    Args:
        system: a preset name.
        algorithms: labels; when omitted, the preset's (the paper's table) valid for the system's parents (a
            saved system of large with 30 parents leaves out ``mgrao-25:1``).
        seeds: a count ``S`` (seeds ``0 .. S-1``) or an explicit list.
        episodes: episodes per run.
        overrides: parameters to change on top of the preset.
        memory_budget: bytes one chunk (every algorithm over one seed, at least) may allocate
            (see :mod:`mgrao_core.budget`).

    Raises:
        ConfigError: a field is invalid; the message names the field and the limit. Every field refused by its
            own rule is named at once (:class:`~mgrao_core.errors.ConfigErrors`, parameters, algorithms, seeds
            and episodes); the limits on their product are checked once each is valid.
        WorkLimitError: the experiment exceeds :data:`MAX_WORK`, :data:`MAX_GROUP_UPDATES`,
            :data:`mgrao_core.budget.MAX_RESULT_BYTES` or, for a single seed, ``memory_budget``.
    """
    preset = get_preset(system)
    errors: list[ConfigError] = []

    def checked(check: Callable[[], T]) -> T | None:
        try:
            return check()
        except ConfigError as error:
            errors.append(error)
            return None

    params = checked(lambda: make_params(overrides, base=preset.params))
    refused = {e.field for error in errors for e in getattr(error, "errors", (error,))}
    # an x of mgrao-x:y is checked against the parents given, or the preset's where other parameters are refused;
    # against the grammar alone where the count of parents is; a y likewise against the children
    parents = None if "n_parents" in refused else (params or preset.params).n_parents
    children = None if "n_children" in refused else (params or preset.params).n_children
    if algorithms is None:  # the preset's, those valid with its parents as overridden (large with 30: no mgrao-25:1)
        given = tuple(preset.algorithms) if parents is None else valid_labels(preset.algorithms, parents, children)
    else:
        given = tuple(algorithms)
    parsed = None
    if len(given) > MAX_ALGORITHMS:
        errors.append(ConfigError("algorithms", f"at most {MAX_ALGORITHMS} algorithms (got {len(given)})"))
    else:
        parsed = checked(lambda: parse_algorithms(given, parents, children))
    labels = None if parsed is None else tuple(a.label for a in parsed)
    checked_seeds = checked(lambda: _seeds(seeds))
    checked_episodes = checked(lambda: _count("episodes", episodes, MAX_EPISODES))
    if params is not None and parsed is not None:  # a learner that cannot say what it keeps cannot run under a cost
        checked(lambda: [task_share(a, params) for a in parsed])
    raise_all(errors)  # every field refused by its own rule, before any limit on their product
    spec = ExperimentSpec(system, params, labels, checked_seeds, checked_episodes)
    one_seed = chunk_cost(spec, 1).total
    if one_seed > memory_budget:
        raise WorkLimitError(
            "memory",
            f"simulating one seed of every algorithm would need {one_seed / 1024**2:,.0f} MiB, over the memory "
            f"budget of {memory_budget / 1024**2:,.0f} MiB per chunk (use fewer algorithms, groups, children, "
            "parents or types)",
        )
    if spec.work > MAX_WORK:
        raise WorkLimitError(
            "work",
            f"seeds x algorithms x episodes x n_parents x types_per_composite = {spec.work:,} "
            f"exceeds the limit of {MAX_WORK:,} atomic tasks per experiment",
        )
    if spec.group_updates > MAX_GROUP_UPDATES:
        raise WorkLimitError(
            "work",
            f"atomic tasks x parent groups (and, for mgrao-adaptive or a hierarchy asking every neighbour, the "
            f"children each composite or failing task visits) = {spec.group_updates:,} exceeds the limit of "
            f"{MAX_GROUP_UPDATES:,} row updates per experiment (use fewer groups, children, seeds or episodes)",
        )
    stored = result_bytes(spec)
    if stored > MAX_RESULT_BYTES:
        raise WorkLimitError(
            "results",
            f"the runs' utilities and weights would take {stored / 1024**2:,.0f} MiB, over the limit of "
            f"{MAX_RESULT_BYTES // 1024**2:,} MiB per experiment (use fewer seeds, episodes or algorithms)",
        )
    return spec


def spec_from_dict(data: Mapping[str, Any], memory_budget: int = MAX_CHUNK_BYTES) -> ExperimentSpec:
    """Rebuild (and re-validate) a specification from :meth:`ExperimentSpec.as_dict` data.

    A ``"when-set"`` parameter absent from ``params`` is at its schema default (even where the preset sets
    another value): :func:`~mgrao_core.params.complete_params`.
    """
    preset = get_preset(data["system"]).params.as_dict()
    stored = complete_params(data.get("params", {}))
    overrides = {k: v for k, v in stored.items() if preset.get(k, object()) != v}
    return make_spec(data["system"], data["algorithms"], list(data["seeds"]), data["episodes"], overrides,
                     memory_budget=memory_budget)
