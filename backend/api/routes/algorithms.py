"""``/api/algorithms``: the core's algorithm registry, served so that no client parses labels of its own."""

from __future__ import annotations

import json
from functools import lru_cache
from typing import Annotated, Any

import orjson
from fastapi import APIRouter, Query, Response

from backend.api.deps import SessionDep
from backend.api.paths import API_PREFIX
from backend.api.responses import Algorithms, answers
from backend.api.schemas import Label, Text
from backend.api.strict_query import StrictQueryRoute
from backend.errors import BadQuery, InvalidSpec
from backend.services import saved_systems
from mgrao_core import PRESETS, ConfigError
from mgrao_core.algorithms import describe_label, registry
from mgrao_core.params import PARAMETERS_BY_NAME, SystemParams, make_params

router = APIRouter(prefix=API_PREFIX, tags=["algorithms"], route_class=StrictQueryRoute)

MAX_LABELS = 50
"""At most this many ``label`` values in one request (a view describes the configurations it shows)."""
MAX_PARAMS_TEXT = 4000
"""Characters of the ``params`` query (a form's overrides as JSON)."""
_PARENTS = PARAMETERS_BY_NAME["n_parents"]


@lru_cache(maxsize=256)
def _resolved(preset: str, overrides: str) -> SystemParams:
    """A preset's parameters with ``overrides`` (canonical JSON) on top (a few hundred kept)."""
    return make_params(json.loads(overrides), base=PRESETS[preset].params)


@lru_cache(maxsize=256)
def _registry(preset: str | None, overrides: str) -> bytes:
    return orjson.dumps({"data": registry(None if preset is None else _resolved(preset, overrides))})


def _overrides(text: str | None) -> dict[str, Any]:
    """The ``params`` query: a JSON object of parameter names to values, or 422 naming ``params``."""
    if text is None:
        return {}
    try:
        value = json.loads(text)
    except ValueError:
        raise BadQuery("params", 'must be a JSON object of parameters, e.g. {"n_parents": 30}') from None
    if not isinstance(value, dict):
        raise BadQuery("params", f'must be a JSON object of parameters, e.g. {{"n_parents": 30}} (got '
                                 f"{type(value).__name__})")
    return value


def _describe(labels: list[str], params: SystemParams | None) -> list[dict[str, Any]]:
    """Each label described; the first refused one is a 422 naming ``label`` (``label[i]`` of several)."""
    out = []
    for i, label in enumerate(labels):
        field = "label" if len(labels) == 1 else f"label[{i}]"
        try:
            out.append(describe_label(label, params, field))
        except ConfigError as error:
            raise BadQuery(field, error.message) from None
    return out


@router.get("/algorithms", response_model=Algorithms, responses=answers())
def algorithms(
    session: SessionDep,
    system: Annotated[Text | None, Query(max_length=32, description="A preset or a saved system: examples, valid "
                                                                    "arguments and memory for its parameters "
                                                                    "(none: the label grammar alone).")] = None,
    n_parents: Annotated[int | None, Query(ge=int(_PARENTS.minimum), le=int(_PARENTS.maximum),
                                           description="The system's parent count when it is not the system's "
                                                       "(a form's override); needs `system`.")] = None,
    params: Annotated[Text | None, Query(max_length=MAX_PARAMS_TEXT,
                                         description='Overrides on top of the system, as a JSON object '
                                                     '({"n_parents": 30, "n_resources": 2}: a form\'s values); '
                                                     "needs `system`.")] = None,
    label: Annotated[list[Label] | None, Query(max_length=MAX_LABELS,
                                              description="Describe these labels instead (repeat the parameter "
                                                          "for several): canonical spelling, family, colour key, "
                                                          "sort key.")] = None,
) -> Response:
    """The algorithm families and how their labels are written, or (``label``) the given labels described."""
    for given, name in ((n_parents, "n_parents"), (params, "params")):
        if given is not None and system is None:
            raise BadQuery(name, "needs system (the system whose parameters it overrides)")
    preset, overrides = None, {}
    if system is not None:
        try:  # a saved system: its base preset and its overrides, the query's on top
            preset, overrides, _ = saved_systems.resolve(session, system, _overrides(params), where=["query", "system"])
        except InvalidSpec as error:
            raise BadQuery("system", error.msg.removeprefix("system: ")) from None
        if n_parents is not None:
            overrides["n_parents"] = n_parents
    canonical = json.dumps(overrides, sort_keys=True, separators=(",", ":"))
    try:
        resolved = None if preset is None else _resolved(preset, canonical)
    except ConfigError as error:
        raise BadQuery(error.field if error.field == "n_parents" and params is None else "params",
                       str(error)) from None
    if label is None:
        return Response(_registry(preset, canonical), media_type="application/json")
    return Response(orjson.dumps({"data": _describe(label, resolved)}), media_type="application/json")
