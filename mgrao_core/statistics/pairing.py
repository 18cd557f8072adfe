"""What pairs with what when configurations are compared: worlds and configurations (docs/statistics.md).

A **world** is what every algorithm of a seed faces: the system, the episodes and every parameter except
the learners' own. Seed ``s`` of a world draws the same parents, values and resources for every algorithm
(common random numbers), so two runs of one world and seed are *paired*: every figure that relates two
configurations is computed on the seeds they share.

A **configuration** is a world, an algorithm label and the values of the parameters that only that
algorithm's learning reads (:attr:`mgrao_core.algorithms.base.Family.own_parameters`: MG-RAO's
``learning_rate``, ``trace_decay``, ``temperature``, ``group_blend`` and ``resource_credit``; the adaptive
family's ``regroup_*`` and MG-RAO's; ``q_*``; ``bandit_step``; and every learner's ``learning_cost``, what its
learning takes from its tasks). ``uniform`` and the ``oracle`` read none,
so a job that changes ``learning_rate`` still pairs its learners with the uniform runs of any job of the
same world. A label no family knows (a run logged from outside) owns every learner parameter: its
configuration is the parameters it was opened with.

The parameters in between are world parameters: the parents' routing and exploration (``epsilon``,
``boltzmann_temperature``, ``initial_estimate``, ``tie_break``) shape the task stream every child faces, and
``resource_credit``, though declared with the resources, is read by MG-RAO's update alone (a learner's).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

from mgrao_core.algorithms import FAMILIES, family_of, parse_algorithm
from mgrao_core.errors import ConfigError
from mgrao_core.params import complete_params

LEARNER_PARAMETERS: tuple[str, ...] = tuple(dict.fromkeys(name for f in FAMILIES for name in f.own_parameters))
"""Every parameter some family's learning reads as its own, in registry order; the others make the world."""


def own_parameters(label: str) -> tuple[str, ...]:
    """The parameters of a configuration of ``label`` beside its world (every learner one for a label of one's own)."""
    try:
        algorithm = parse_algorithm(label, None)
    except ConfigError:
        return LEARNER_PARAMETERS
    return family_of(algorithm).own_parameters


def world(config: Mapping[str, Any]) -> dict[str, Any]:
    """The world of a job's configuration (``{"system", "params", "episodes", ...}``).

    Its system, its episodes and every parameter but the learners', complete (an absent one at its default).
    """
    params = complete_params(config["params"])
    return {"system": config["system"], "episodes": config["episodes"],
            "params": {k: v for k, v in params.items() if k not in LEARNER_PARAMETERS}}


def world_digest(config: Mapping[str, Any]) -> str:
    """sha256 of the canonical JSON of :func:`world`: equal for every job of one world, whatever its learners."""
    text = json.dumps(world(config), sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def own_values(label: str, config: Mapping[str, Any]) -> dict[str, Any]:
    """The values of ``label``'s own parameters (:func:`own_parameters`) in a job's configuration."""
    params = complete_params(config["params"])
    return {name: params[name] for name in own_parameters(label) if name in params}
