"""The paper's four simulated systems (section 5, appendix "Simulation parameter values"), and systems beyond them.

:data:`PAPER_SYSTEMS` names the paper's four: ``mgrao reproduce`` and the paper view run those, never every
preset. The others (``drift``, ``bursty``, ``multi-resource``, ``cloud``, ``edge``) exercise the parts of the paper's
system model its experiments leave out (docs/model.md, "Task frequencies", "Changes over time", "Several resources",
"A cloud", "An edge": a sparse world of thousands of agents).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from mgrao_core.errors import ConfigError
from mgrao_core.params import SystemParams, make_params


@dataclass(frozen=True)
class Preset:
    """A named system: parameter overrides on the defaults and the paper's algorithms for it.

    ``paper_pct_from_uniform`` and ``paper_pct_of_max`` are the paper's published tables (its
    macros ``resultSingleMgraoMax`` etc.), as printed, not recomputed from each other.
    """

    name: str
    description: str
    overrides: dict[str, Any]
    algorithms: tuple[str, ...]
    paper_pct_from_uniform: dict[str, float] = field(default_factory=dict)
    paper_pct_of_max: dict[str, float] = field(default_factory=dict)

    @property
    def params(self) -> SystemParams:
        """The preset's full parameter set."""
        return make_params(self.overrides)


PRESETS: dict[str, Preset] = {
    "single": Preset(
        "single",
        "10 parents, 1 child: a stable task stream from every parent.",
        {"n_parents": 10, "n_children": 1},
        ("uniform", "mgrao-1:1", "mgrao-max"),
        {"mgrao-max": 28.0, "mgrao-1:1": 23.4},
        {"mgrao-max": 100.0, "mgrao-1:1": 83.7},
    ),
    "multi": Preset(
        "multi",
        "10 parents, 3 children: parents choose children epsilon-greedily by estimated value.",
        {"n_parents": 10, "n_children": 3},
        ("uniform", "mgrao-1:1", "mgrao-max"),
        {"mgrao-max": 23.8, "mgrao-1:1": 21.4},
        {"mgrao-max": 100.0, "mgrao-1:1": 90.0},
    ),
    "volatile": Preset(
        "volatile",
        "10 parents, 1 child: each parent leaves and rejoins with probability 0.25 per episode.",
        {"n_parents": 10, "n_children": 1, "leave_probability": 0.25, "join_probability": 0.25},
        ("uniform", "mgrao-1:1", "mgrao-max"),
        {"mgrao-max": 7.1, "mgrao-1:1": 3.3},
        {"mgrao-max": 100.0, "mgrao-1:1": 46.5},
    ),
    "large": Preset(
        "large",
        "50 parents, 1 child: group counts 1, 2, 5, 10, 25 and 50.",
        {"n_parents": 50, "n_children": 1},
        ("uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-25:1", "mgrao-max"),
        {
            "mgrao-max": 19.6, "mgrao-1:1": 14.7, "mgrao-2:1": 17.2,
            "mgrao-5:1": 17.9, "mgrao-10:1": 18.9, "mgrao-25:1": 19.5,
        },
        {
            "mgrao-max": 100.0, "mgrao-1:1": 75.1, "mgrao-2:1": 87.7,
            "mgrao-5:1": 91.0, "mgrao-10:1": 96.6, "mgrao-25:1": 99.4,
        },
    ),
    "drift": Preset(
        "drift",
        "single, but at episode 50 of 100, 30% of the parents draw new value profiles: does learning recover?",
        {"n_parents": 10, "n_children": 1,
         "schedule": [{"episode": 50, "change": "new-profiles", "fraction": 0.3}]},
        ("uniform", "mgrao-1:1", "mgrao-max"),
    ),
    "bursty": Preset(
        "bursty",
        "large, but half the composite types arrive every episode and half every 4th: unequal sample counts.",
        {"n_parents": 50, "n_children": 1, "frequency_profile": "two-speed", "slow_period": 4},
        ("uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-25:1", "mgrao-max"),
    ),
    "multi-resource": Preset(
        "multi-resource",
        "single, but each child owns two resources and each atomic type needs them in its own proportions.",
        {"n_parents": 10, "n_children": 1, "n_resources": 2, "need_concentration": 1.0},
        ("uniform", "mgrao-1:1", "mgrao-max"),
    ),
    "cloud": Preset(
        "cloud",
        "40 services send composite requests of 4 atomic tasks to 8 servers with CPU and memory; a task fails "
        "without enough memory and borrows it from a neighbouring server (docs/model.md, \"A cloud\").",
        {"n_parents": 40, "n_children": 8, "n_types": 12, "types_per_composite": 4, "n_resources": 2,
         "need_concentration": 1.0, "routing": "per-task", "load_sharing": True, "task_need": 0.45,
         "hierarchy": "borrow"},
        ("uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max", "mgrao-balance", "oracle"),
    ),
    "edge": Preset(
        "edge",
        "5,000 mobile users send composite requests to 500 edge servers; each user reaches only the 4 servers nearest "
        "to it, and tasks on one server share its resources (docs/model.md, \"An edge\").",
        {"n_parents": 5000, "n_children": 500, "topology": "ring", "children_per_parent": 4, "routing": "per-task",
         "load_sharing": True},
        ("uniform", "mgrao-1:1", "mgrao-10:1", "mgrao-100:1"),
    ),
}
PAPER_SYSTEMS: tuple[str, ...] = ("single", "multi", "volatile", "large")
"""The paper's four systems, in its order: what ``mgrao reproduce`` and the paper view run."""


def get_preset(name: str) -> Preset:
    """The preset called ``name``.

    Raises:
        ConfigError: ``name`` is no preset's (single, multi, volatile, large, drift, bursty, multi-resource, cloud,
            edge).
    """
    try:
        return PRESETS[name]
    except (KeyError, TypeError):
        raise ConfigError("system", f"unknown system {name!r}: use one of {', '.join(PRESETS)}") from None
