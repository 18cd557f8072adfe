"""``/api/algorithms``: the core's algorithm registry, served so that no client parses labels of its own."""

from __future__ import annotations

from functools import cache
from typing import Annotated, Any, Literal

import orjson
from fastapi import APIRouter, Query, Response

from backend.api.paths import API_PREFIX
from backend.api.responses import Algorithms, answers
from backend.api.schemas import Label
from backend.errors import BadQuery
from mgrao_core import PRESETS, ConfigError
from mgrao_core.algorithms import describe_label, registry
from mgrao_core.params import PARAMETERS_BY_NAME, SystemParams, make_params

router = APIRouter(prefix=API_PREFIX, tags=["algorithms"])

MAX_LABELS = 50
"""At most this many ``label`` values in one request (a view describes the configurations it shows)."""
SystemName = Literal[tuple(PRESETS)]  # type: ignore[valid-type]
_PARENTS = PARAMETERS_BY_NAME["n_parents"]


@cache
def _params(system: str | None, n_parents: int | None) -> SystemParams | None:
    """The parameters the answer is for: a preset's, with ``n_parents`` overridden; None without a system."""
    if system is None:
        return None
    base = PRESETS[system].params
    return base if n_parents is None else make_params({"n_parents": n_parents}, base=base)


@cache
def _registry(system: str | None, n_parents: int | None) -> bytes:
    return orjson.dumps({"data": registry(_params(system, n_parents))})


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
    system: Annotated[SystemName | None, Query(description="A preset: examples, valid arguments and memory for "
                                                           "its parameters (none: the label grammar alone).")] = None,
    n_parents: Annotated[int | None, Query(ge=int(_PARENTS.minimum), le=int(_PARENTS.maximum),
                                           description="The system's parent count when it is not the preset's "
                                                       "(a form's override); needs `system`.")] = None,
    label: Annotated[list[Label] | None, Query(max_length=MAX_LABELS,
                                              description="Describe these labels instead (repeat the parameter "
                                                          "for several): canonical spelling, family, colour key, "
                                                          "sort key.")] = None,
) -> Response:
    """The algorithm families and how their labels are written, or (``label``) the given labels described."""
    if n_parents is not None and system is None:
        raise BadQuery("n_parents", "needs system (the preset whose parent count it overrides)")
    try:
        params = _params(system, n_parents)
    except ConfigError as error:
        raise BadQuery(error.field, error.message) from None
    if label is None:
        return Response(_registry(system, n_parents), media_type="application/json")
    return Response(orjson.dumps({"data": _describe(label, params)}), media_type="application/json")
