"""``/api/systems``: presets, the parameter schema, algorithms and limits."""

from __future__ import annotations

from functools import cache

from fastapi import APIRouter

from backend.api.deps import SettingsDep
from backend.api.responses import Systems, answers
from backend.store.crud import config_hash
from mgrao_core import (
    MAX_ALGORITHMS,
    MAX_EPISODES,
    MAX_SEEDS,
    MAX_WORK,
    PARAMETERS,
    PRESETS,
    WORK_FACTORS,
    make_spec,
    search,
)
from mgrao_core.algorithms import ORACLE, registry, sort_key
from mgrao_core.reproduction import PAPER_EPISODES
from mgrao_core.stats import BASELINE, REFERENCE


@cache
def paper_config_hash(system: str) -> str:
    """The ``config_hash`` of the paper's experiment of ``system``: its preset unchanged, 100 episodes.

    A job has it whatever its seeds, algorithms, name or tags (``GET /api/jobs?config_hash=``).
    """
    return config_hash(make_spec(system, seeds=1, episodes=PAPER_EPISODES).as_dict())


@cache
def algorithm_labels() -> dict:
    """``algorithms`` of the answer, from the core's registry (GET /api/algorithms has the whole of it).

    ``fixed``: every family's example labels of the grammar alone, in view order; ``pattern``: the
    label forms that take an argument, ``<x>`` where it goes; ``baseline``, ``reference`` and
    ``best_fixed``: the labels that % from uniform, % of max and the weights' best fixed allocation read.
    """
    families = registry(None)
    fixed = sorted({label for f in families for label in f["examples"]}, key=sort_key)
    pattern = ", ".join(form["template"].replace(f"{{{form['argument']}}}", f"<{form['argument']}>")
                        for f in families for form in f["forms"] if form["argument"] is not None)
    return {"fixed": fixed, "pattern": pattern, "baseline": BASELINE, "reference": REFERENCE, "best_fixed": ORACLE}


router = APIRouter(prefix="/api", tags=["systems"])


@router.get("/systems", response_model=Systems, responses=answers(invalid=False))
def systems(settings: SettingsDep) -> dict:
    """What can be submitted: systems, parameters, algorithm labels, limits and the studies' limits.

    ``limits.max_work`` bounds the product of ``limits.work_factors``: the number of seeds and of
    algorithms, the episodes and the named parameters (the form shows the budget as it fills).
    """
    return {
        "systems": [
            {"name": p.name, "description": p.description, "params": p.params.as_dict(),
             "algorithms": list(p.algorithms), "paper": dict(p.paper_pct_from_uniform),
             "paper_pct_of_max": dict(p.paper_pct_of_max), "paper_config_hash": paper_config_hash(p.name)}
            for p in PRESETS.values()
        ],
        "parameters": [p.as_dict() for p in PARAMETERS],
        "algorithms": algorithm_labels(),
        "limits": {"max_seeds": MAX_SEEDS, "max_episodes": MAX_EPISODES, "max_algorithms": MAX_ALGORITHMS,
                   "max_work": MAX_WORK, "work_factors": list(WORK_FACTORS),
                   "max_body_bytes": settings.max_body_bytes},
        "studies": {"methods": list(search.METHODS), "metrics": list(search.METRICS),
                    "max_trials": search.MAX_TRIALS, "max_in_flight": search.MAX_IN_FLIGHT,
                    "max_dimensions": search.MAX_DIMENSIONS, "max_steps": search.MAX_STEPS,
                    "max_values": search.MAX_VALUES, "group_label": search.GROUP_LABEL},
    }
