"""``/api/studies``: submit, list, read, plot, cancel, re-run failed trials, delete."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Path, Query, Response, status
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from backend.api.deps import Authorized, DatabaseDep, SessionDep
from backend.api.links import JOB, STUDY, links
from backend.api.responses import LOCATION, StudyDetail, StudyPage, StudyPlots, answers
from backend.api.schemas import StudyCreate, Text
from backend.api.strict_query import StrictQueryRoute
from backend.errors import InvalidSpec
from backend.services import analysis, saved_systems, studies
from backend.services.cache import AnswerCache
from backend.services.study_plots import study_plots
from backend.store.keyset import Keyset
from backend.store.models import MAX_JOB_ID, Study
from mgrao_core import PRESETS, ConfigError
from mgrao_core.search import make_plan

router = APIRouter(prefix="/api/studies", tags=["studies"], route_class=StrictQueryRoute)

StudyId = Annotated[int, Path(ge=1, le=MAX_JOB_ID)]
StudySort = Literal["-created_at", "created_at", "name", "-name", "status", "-status"]
ANSWERS = AnswerCache(max_bytes=64 * 1024**2)
STUDY_DETAIL_LINKS = links(STUDY, "/study/id") | links({"trial_job": JOB["read"]}, "/trials/0/job_ids/0")
"""From a study's answer: the operations on it, and its first trial's first job."""
_COLUMNS = {"created_at": Study.created_at, "name": Study.name, "status": Study.status}


def _json(data: Any, code: int = 200) -> Response:
    return Response(analysis.dumps(data), media_type="application/json", status_code=code)


@router.post("", status_code=status.HTTP_202_ACCEPTED, response_model=StudyDetail, dependencies=[Authorized],
             responses=answers(write=True, extra={202: {"description": "Stored.", "headers": LOCATION,
                                                        "links": STUDY_DETAIL_LINKS}}))
def submit_study(db: DatabaseDep, body: StudyCreate) -> Response:
    """Validate a study (docs/studies.md), store it and queue its first trials."""
    data = body.model_dump(exclude_unset=True)
    base = data.get("base", {})
    if isinstance(base.get("system"), str):  # a saved system: its base preset, its overrides under the base's params
        with db.session() as session:
            system, params, _ = saved_systems.resolve(session, base["system"], base.get("params", {}),
                                                      ["body", "base", "system"])
        data["base"] = base | {"system": system, "params": params}
    elif isinstance(base.get("system"), list):  # saved systems among presets: each inlined under its own name
        with db.session() as session:
            data["base"] = base | {"system": [name if name in PRESETS else _named(session, name, i)
                                              for i, name in enumerate(base["system"])]}
    try:
        plan = make_plan(data)
    except ConfigError as error:
        raise InvalidSpec(_location(error.field), error.field, str(error)) from None
    db.require_room()
    study_id = studies.create_study(db, plan=plan)
    with db.session() as session:
        detail = studies.study_detail(session, study_id)
    response = _json(detail, status.HTTP_202_ACCEPTED)
    response.headers["Location"] = f"/api/studies/{study_id}"
    return response


def _named(session: Session, name: str, index: int) -> dict[str, Any]:
    """A saved system in a study's list of systems, inlined: its name, base preset and overrides (as stored now)."""
    system, params, _ = saved_systems.resolve(session, name, {}, ["body", "base", "system", index])
    return {"name": name, "system": system, "params": params}


def _location(field: str) -> list[str | int]:
    """``space.learning_rate.values[2]`` as a validation error's ``loc``: body, space, learning_rate, values, 2."""
    loc: list[str | int] = ["body"]
    for part in field.split("."):
        name, *indices = part.replace("]", "").split("[")
        loc.append(name)
        loc.extend(int(i) for i in indices if i.isdigit())
    return loc


@router.get("", response_model=StudyPage, responses=answers(extra={200: {"description": "A page of studies.",
                                                                         "links": links(STUDY, "/data/0/id")}}))
def list_studies(
    session: SessionDep,
    status_: Annotated[Literal["running", "finished", "cancelled"] | None, Query(alias="status")] = None,
    method: Literal["grid", "random", "tpe"] | None = None,
    q: Annotated[Text | None, Query(max_length=200, description="Text in the name.")] = None,
    sort: StudySort = "-created_at",
    limit: Annotated[int, Query(ge=1, le=200)] = 50,
    cursor: Annotated[Text | None, Query(max_length=500)] = None,
) -> Response:
    """Studies matching the filters, one page at a time (keyset pagination), with trials per status."""
    column = _COLUMNS[sort.lstrip("-")]
    order = Keyset(sort, sort.startswith("-"), column, "datetime" if column is Study.created_at else "text", Study.id,
                   "study")
    clauses = []
    if status_:
        clauses.append(Study.status == status_)
    if method:
        clauses.append(Study.method == method)
    if q:
        clauses.append(func.lower(Study.name).contains(q.lower(), autoescape=True))
    total = session.scalar(select(func.count()).select_from(Study).where(*clauses)) or 0
    rows = list(session.scalars(order.apply(select(Study).where(*clauses), cursor).limit(limit + 1)))
    next_cursor = None
    if len(rows) > limit:
        rows = rows[:limit]
        next_cursor = order.encode(getattr(rows[-1], column.key), rows[-1].id)
    counts = studies.trial_counts(session, [s.id for s in rows])
    return _json({"data": [studies.study_dict(s, counts[s.id]) for s in rows], "next_cursor": next_cursor,
                  "count": total})


def _version(session: Session, study_id: int) -> tuple:
    """What a study's cached answers are keyed by: its database, id, creation and revision."""
    study = studies.get_study(session, study_id)
    return str(session.get_bind().url), study_id, study.created_at, study.revision


@router.get("/{study_id:int}", response_model=StudyDetail, responses=answers(found=True, extra={
    200: {"description": "The study.", "links": STUDY_DETAIL_LINKS}}))
def read_study(study_id: StudyId, session: SessionDep,
               trials: Annotated[bool, Query(description="false: the study and its definition only (for polling).")]
               = True) -> Response:
    """The study, its definition, and every trial with its parameters, objective (95% CI), status and jobs."""
    body = ANSWERS.get_or_build(("detail", *_version(session, study_id), trials),
                                lambda: analysis.dumps(studies.study_detail(session, study_id, trials=trials)))
    return Response(body, media_type="application/json")


@router.get("/{study_id:int}/plots", response_model=StudyPlots, responses=answers(found=True))
def plot_study(study_id: StudyId, session: SessionDep,
               x: Annotated[Text | None, Query(max_length=64)] = None,
               y: Annotated[Text | None, Query(max_length=64)] = None) -> Response:
    """Best so far, importance, slices, a heatmap of two dimensions and parallel coordinates, aggregated."""
    body = ANSWERS.get_or_build(("plots", *_version(session, study_id), x, y),
                                lambda: analysis.dumps(study_plots(session, study_id, x, y)))
    return Response(body, media_type="application/json")


@router.post("/{study_id:int}/cancel", response_model=StudyDetail, dependencies=[Authorized],
             responses=answers(write=True, found=True, conflict=True, extra={
                 200: {"description": "Cancelled.", "links": STUDY_DETAIL_LINKS}}))
def cancel_study(study_id: StudyId, db: DatabaseDep) -> Response:
    """Cancel a running study with its queued and running trials (409 otherwise)."""
    studies.cancel_study(db, study_id=study_id)
    with db.session() as session:
        return _json(studies.study_detail(session, study_id))


@router.post("/{study_id:int}/rerun-failed", response_model=StudyDetail, dependencies=[Authorized],
             responses=answers(write=True, found=True, conflict=True, extra={
                 200: {"description": "Trials queued again.", "links": STUDY_DETAIL_LINKS}}))
def rerun_failed(study_id: StudyId, db: DatabaseDep) -> Response:
    """Run the failed and cancelled trials again (same parameters, same numbers; no cell twice)."""
    db.require_room()
    count = studies.rerun_failed(db, study_id=study_id)
    with db.session() as session:
        return _json(studies.study_detail(session, study_id) | {"rerun": count})


@router.delete("/{study_id:int}", status_code=status.HTTP_204_NO_CONTENT, dependencies=[Authorized],
               responses=answers(write=True, found=True, conflict=True))
def delete_study(study_id: StudyId, db: DatabaseDep) -> Response:
    """Delete a study with its trials and their jobs (409 while one of its jobs runs)."""
    studies.delete_study(db, study_id=study_id)
    return Response(status_code=status.HTTP_204_NO_CONTENT)
