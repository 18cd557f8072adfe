"""``/api/systems``: presets, the parameter schema, algorithms and limits."""

from __future__ import annotations

from functools import cache
from typing import Annotated

from fastapi import APIRouter, Path, Response, status

from backend.api.deps import Authorized, DatabaseDep, SettingsDep
from backend.api.links import SAVED, links
from backend.api.paths import API_PREFIX
from backend.api.responses import LOCATION, Systems, answers
from backend.api.schemas import SavedSystemIn, SavedSystemOut
from backend.api.strict_query import StrictQueryRoute
from backend.errors import InvalidSpec
from backend.services import saved_systems
from backend.services.analysis import MAX_RESPONSE_VALUES
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
from mgrao_core.params import GROUP_TITLES
from mgrao_core.presets import PAPER_SYSTEMS
from mgrao_core.reproduction import PAPER_EPISODES
from mgrao_core.statistics import sequential
from mgrao_core.statistics.summary import BASELINE, REFERENCE


@cache
def paper_config_hash(system: str) -> str | None:
    """The ``config_hash`` of the paper's experiment of ``system``: its preset unchanged, 100 episodes.

    A job has it whatever its seeds, algorithms, name or tags (``GET /api/jobs?config_hash=``). None for
    a preset that is not one of the paper's four (:data:`~mgrao_core.presets.PAPER_SYSTEMS`: ``drift``,
    ``bursty`` and later ones are no experiment of the paper).
    """
    if system not in PAPER_SYSTEMS:
        return None
    return config_hash(make_spec(system, seeds=1, episodes=PAPER_EPISODES).as_dict())


@cache
def algorithm_labels() -> dict:
    """``algorithms`` of the answer, from the core's registry (GET /api/algorithms has the whole of it).

    ``fixed``: every family's example labels of the grammar alone, in view order; ``pattern``: the
    label forms that take an argument, ``<x>`` where it goes (and ``<y>`` a second); ``baseline``, ``reference`` and
    ``best_fixed``: the labels that % from uniform, % of max and the weights' best fixed allocation read.
    """
    families = registry(None)
    fixed = sorted({label for f in families for label in f["examples"]}, key=sort_key)
    def shown(form: dict) -> str:
        text = form["template"]
        for name in filter(None, (form["argument"], form.get("second_argument"))):
            text = text.replace(f"{{{name}}}", f"<{name}>")
        return text

    pattern = ", ".join(shown(form) for f in families for form in f["forms"] if form["argument"] is not None)
    return {"fixed": fixed, "pattern": pattern, "baseline": BASELINE, "reference": REFERENCE, "best_fixed": ORACLE}


router = APIRouter(prefix=API_PREFIX, tags=["systems"], route_class=StrictQueryRoute)


@router.get("/systems", response_model=Systems, responses=answers())
def systems(settings: SettingsDep, db: DatabaseDep) -> dict:
    """What can be submitted: systems, saved systems, parameters, algorithm labels, limits and the studies' limits.

    ``limits.max_work`` bounds the product of ``limits.work_factors``: the number of seeds and of
    algorithms, the episodes and the named parameters (the form shows the budget as it fills).
    ``saved``: the researchers' saved systems (``/api/systems/saved``), each usable as a ``system``.
    """
    with db.session() as session:
        saved = [saved_systems.saved_dict(s) for s in saved_systems.list_saved(session)]
    return {
        "saved": saved,
        "systems": [
            {"name": p.name, "description": p.description, "params": p.params.as_dict(),
             "algorithms": list(p.algorithms), "paper": dict(p.paper_pct_from_uniform),
             "paper_pct_of_max": dict(p.paper_pct_of_max), "paper_config_hash": paper_config_hash(p.name)}
            for p in PRESETS.values()
        ],
        "parameters": [p.as_dict() for p in PARAMETERS],
        "group_titles": GROUP_TITLES,
        "algorithms": algorithm_labels(),
        "limits": {"max_seeds": MAX_SEEDS, "max_episodes": MAX_EPISODES, "max_algorithms": MAX_ALGORITHMS,
                   "max_work": MAX_WORK, "work_factors": list(WORK_FACTORS),
                   "max_body_bytes": settings.max_body_bytes, "max_response_values": MAX_RESPONSE_VALUES,
                   "until": {"of": list(sequential.OF), "min_seeds": sequential.MIN_SEEDS,
                             "not_judged": list(sequential.NOT_JUDGED),
                             "max_seeds": sequential.DEFAULT_MAX_SEEDS, "block": sequential.DEFAULT_BLOCK,
                             "max_half_width": sequential.MAX_HALF_WIDTH}},
        "studies": {"methods": list(search.METHODS), "metrics": list(search.METRICS),
                    "max_trials": search.MAX_TRIALS, "max_in_flight": search.MAX_IN_FLIGHT,
                    "max_dimensions": search.MAX_DIMENSIONS, "max_steps": search.MAX_STEPS,
                    "max_values": search.MAX_VALUES, "group_label": search.GROUP_LABEL,
                    "team_label": search.TEAM_LABEL},
    }


SavedName = Annotated[str, Path(pattern=saved_systems.NAME_PATTERN, description="The saved system's name.")]


@router.get("/systems/saved", response_model=list[SavedSystemOut], responses=answers(extra={
    200: {"description": "The saved systems.", "links": links(SAVED, "/0/name")}}))
def list_saved_systems(db: DatabaseDep) -> list[dict]:
    """Every saved system, by name."""
    with db.session() as session:
        return [saved_systems.saved_dict(s) for s in saved_systems.list_saved(session)]


@router.post("/systems/saved", status_code=status.HTTP_201_CREATED, response_model=SavedSystemOut,
             dependencies=[Authorized],
             responses=answers(write=True, conflict=True, extra={201: {"description": "Saved.", "headers": LOCATION,
                                                                          "links": links(SAVED, "/name")}}))
def save_system(body: SavedSystemIn, db: DatabaseDep, response: Response) -> dict:
    """Save a named system: a base preset and overrides (validated on it), usable as a job's or study's system."""
    db.require_room()
    with db.write() as session:
        saved = saved_systems.create_saved(session, name=body.name, description=body.description, base=body.base,
                                           params=body.params)
        out = saved_systems.saved_dict(saved)
    response.headers["Location"] = f"/api/systems/saved/{body.name}"
    return out


@router.get("/systems/saved/{name}", response_model=SavedSystemOut, responses=answers(found=True, extra={
    200: {"description": "The saved system.", "links": links(SAVED, "/name", without=["read"])}}))
def read_saved_system(name: SavedName, db: DatabaseDep) -> dict:
    """One saved system (its ``name``, ``description``, ``base`` and ``params`` are its file)."""
    with db.session() as session:
        return saved_systems.saved_dict(saved_systems.get_saved(session, name=name))


@router.put("/systems/saved/{name}", response_model=SavedSystemOut, dependencies=[Authorized],
            responses=answers(write=True, found=True, extra={200: {"description": "Replaced.",
                                                                   "links": links(SAVED, "/name")}}))
def replace_saved_system(name: SavedName, body: SavedSystemIn, db: DatabaseDep) -> dict:
    """Replace a saved system's description, base and overrides (the body's name must be the path's)."""
    if body.name != name:
        raise InvalidSpec(["body", "name"], "name", f"name: must be the saved system's name {name!r} (got "
                                                    f"{body.name!r}); save under another name with POST")
    with db.write() as session:
        saved = saved_systems.replace_saved(session, name=name, description=body.description, base=body.base,
                                            params=body.params)
        return saved_systems.saved_dict(saved)


@router.delete("/systems/saved/{name}", status_code=status.HTTP_204_NO_CONTENT, dependencies=[Authorized],
               responses=answers(write=True, found=True))
def delete_saved_system(name: SavedName, db: DatabaseDep) -> Response:
    """Forget a saved system; the jobs run from it keep their configuration and their tag."""
    with db.write() as session:
        saved_systems.delete_saved(session, name=name)
    return Response(status_code=status.HTTP_204_NO_CONTENT)
