"""``/api/external-runs``: runs logged from outside (docs/platform.md): open, send batches, close, read.

An external run is a job of kind ``external``: it is listed, read, labelled, compared and deleted as any
job (``/api/jobs``); these routes only write its episodes. Every write is protected as the other
writes are (bearer token, same origin) and every body is under ``MGRAO_MAX_BODY_BYTES``.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path, Response, status
from sqlalchemy.orm import Session

from backend.api.deps import Authorized, DatabaseDep, SessionDep, SettingsDep
from backend.api.links import RUN, links
from backend.api.responses import LOCATION, ExternalBatchOut, ExternalRunState, answers
from backend.api.schemas import ExternalBatchIn, ExternalRunCreate
from backend.api.strict_query import StrictQueryRoute
from backend.services.external import batch_content, external_config
from backend.settings import Settings
from backend.store import external
from backend.store.models import MAX_JOB_ID

router = APIRouter(prefix="/api/external-runs", tags=["external runs"], route_class=StrictQueryRoute)

RunId = Annotated[int, Path(ge=1, le=MAX_JOB_ID, description="An external run's id (its job's id).")]
RUN_LINKS = links(RUN, "/job/id")


def _answer(session: Session, job_id: int, settings: Settings) -> dict[str, Any]:
    run = external.state(session, job_id=job_id)
    params = run["job"]["params"]
    return run | {"limits": {"max_body_bytes": settings.max_body_bytes, "max_batch_entries": external.MAX_BATCH_ENTRIES,
                             "max_piece_values": external.MAX_PIECE_VALUES,
                             "max_pieces_per_seed": external.MAX_PIECES_PER_SEED,
                             "weights_shape": [params["n_children"], params["n_types"]]}}


@router.post("", status_code=status.HTTP_201_CREATED, response_model=ExternalRunState, dependencies=[Authorized],
             responses=answers(write=True, conflict=True, extra={
                 201: {"description": "Opened.", "headers": LOCATION, "links": RUN_LINKS},
                 200: {"description": "Already opened with this key and definition: the same run.",
                       "model": ExternalRunState, "headers": LOCATION, "links": RUN_LINKS}}))
def open_external_run(body: ExternalRunCreate, db: DatabaseDep, settings: SettingsDep, response: Response) -> dict:
    """Open a run logged from outside: its label, its world (system, parameters, seeds, episodes); status open."""
    config = external_config(body)
    db.require_room()
    with db.write() as session:
        job, created = external.open_run(session, config=config, name=body.name, tags=body.tags, notes=body.notes,
                                         open_key=body.key)
        answer = _answer(session, job.id, settings)
    response.status_code = status.HTTP_201_CREATED if created else status.HTTP_200_OK
    response.headers["Location"] = f"/api/external-runs/{job.id}"
    return answer


@router.get("/{job_id:int}", response_model=ExternalRunState, responses=answers(found=True, extra={
    200: {"description": "The run.", "links": links(RUN, "/job/id", without=["read_run"])}}))
def read_external_run(job_id: RunId, session: SessionDep, settings: SettingsDep) -> dict:
    """An external run: its job, each seed's episodes stored so far, and what a batch may hold."""
    return _answer(session, job_id, settings)


@router.post("/{job_id:int}/batches", response_model=ExternalBatchOut, dependencies=[Authorized],
             responses=answers(write=True, found=True, conflict=True, extra={
                 200: {"description": "Stored (or replayed).", "links": links(RUN, "$request.path.job_id")}}))
def add_batch(job_id: RunId, body: ExternalBatchIn, db: DatabaseDep) -> dict:
    """Store a batch of episode utilities (and seeds' final weights) once: a batch sent again with its key is not."""
    with db.session() as session:
        config = external.get_external(session, job_id).config
    digest, pieces, weights = batch_content(body, config)
    db.require_room()
    with db.write() as session:
        return external.append_batch(session, job_id=job_id, key=body.key, digest=digest, pieces=pieces,
                                     weights=weights)


@router.post("/{job_id:int}/close", response_model=ExternalRunState, dependencies=[Authorized],
             responses=answers(write=True, found=True, conflict=True, extra={
                 200: {"description": "Closed.", "links": links(RUN, "/job/id", without=["batch", "close"])}}))
def close_external_run(job_id: RunId, db: DatabaseDep, settings: SettingsDep) -> dict:
    """Close a run whose every seed is complete: it becomes succeeded, with its summaries (closed again: the same)."""
    with db.write() as session:
        external.close_run(session, job_id=job_id)
        return _answer(session, job_id, settings)
