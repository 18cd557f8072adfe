"""Light reads for the dashboard: whether jobs changed, where one job stands, whether an experiment would be taken.

``/api/jobs/changes``: has any job changed since a token the client holds; ``/api/jobs/{id}/status``:
what a queued job waits for and whether runs are stored yet; ``POST /api/jobs/check``: a submission's
validation without queuing it, answered 200 either way (a refusal is a state of the form, not an error).
"""

from __future__ import annotations

import hashlib
from typing import Annotated, Any

from fastapi import APIRouter, Body, Path, Query
from fastapi.responses import JSONResponse
from pydantic import ValidationError
from sqlalchemy import and_, func, or_, select
from sqlalchemy.orm import Session

from backend.api import submission
from backend.api.deps import DatabaseDep, SessionDep, SettingsDep
from backend.api.responses import JobChanges, JobCheck, JobStatus, answers
from backend.api.schemas import JobCreate
from backend.api.strict_query import StrictQueryRoute
from backend.api.validation import validation_detail, validation_details
from backend.errors import InvalidSpec
from backend.execution import presence
from backend.services import saved_systems
from backend.store import crud
from backend.store.models import MAX_JOB_ID, OPEN, QUEUED, RUNNING, Job, Run
from mgrao_core import MAX_WORK, ConfigError, WorkLimitError

router = APIRouter(prefix="/api/jobs", tags=["jobs"], route_class=StrictQueryRoute)

TOKEN_CHARS = 16
Since = Annotated[str | None, Query(max_length=TOKEN_CHARS, pattern="^[0-9a-f]*$",
                                    description="The token of the previous answer (16 hex digits).")]


def jobs_token(session: Session) -> tuple[str, dict[str, int]]:
    """A token of the jobs' state and the queue's counts (jobs per status).

    The token moves when a job is submitted or deleted (count and highest id per status), changes
    status, or when a queued, running or open (external) job's progress or attempt count moves. Two index scans of
    ``ix_jobs_status_created`` and a read of the active jobs' rows: no job's config or runs are read.
    A name, tags or notes edit does not move it.
    """
    per_status = session.execute(
        select(Job.status, func.count(), func.max(Job.id)).group_by(Job.status).order_by(Job.status)
    ).all()
    active = session.execute(
        select(func.count(), func.sum(Job.progress), func.sum(Job.attempts))
        .where(Job.status.in_((QUEUED, RUNNING, OPEN)))
    ).one()
    state = repr(([tuple(row) for row in per_status], tuple(active)))
    token = hashlib.blake2b(state.encode(), digest_size=TOKEN_CHARS // 2).hexdigest()
    return token, {status: count for status, count, _ in per_status}


@router.get("/changes", response_model=JobChanges, responses=answers())
def job_changes(session: SessionDep, since: Since = None) -> JSONResponse:
    """``{"changed": false}`` while the jobs' token equals ``since``; else the new token and the queue's counts.

    One light request per poll for the dashboard's runs table and header: the client keeps the
    token, reloads what it shows when ``changed`` is true, and asks again. Never cached.
    """
    token, counts = jobs_token(session)
    headers = {"Cache-Control": "no-store"}
    if since == token:
        return JSONResponse({"changed": False}, headers=headers)
    return JSONResponse({"changed": True, "token": token, "queued": counts.get(QUEUED, 0),
                         "running": counts.get(RUNNING, 0)}, headers=headers)


@router.get("/{job_id:int}/status", response_model=JobStatus, responses=answers(found=True))
def job_status(job_id: Annotated[int, Path(ge=1, le=MAX_JOB_ID, description="A job's id.")], session: SessionDep,
               settings: SettingsDep) -> dict:
    """Where a job stands: its status and progress, the runs stored so far, and what a queued job waits for.

    ``ahead`` counts the queued jobs that workers take before this one (oldest first; 0 unless it is
    queued), ``running`` the jobs running now and ``workers`` the workers seen by state (as in
    ``/api/health``). ``stored_runs`` is 0 until the first chunk is stored (``/results`` answers 409 then).
    """
    job = crud.get_job(session, job_id=job_id)
    ahead = 0
    if job.status == QUEUED:
        ahead = session.scalar(select(func.count()).select_from(Job).where(
            Job.status == QUEUED,
            or_(Job.created_at < job.created_at, and_(Job.created_at == job.created_at, Job.id < job.id))))
    return {
        "id": job.id, "status": job.status, "progress": job.progress, "ahead": ahead,
        "running": session.scalar(select(func.count()).select_from(Job).where(Job.status == RUNNING)),
        "workers": presence.counts(session, stale_after_s=settings.stale_after_s),
        "stored_runs": session.scalar(select(func.count()).select_from(Run).where(Run.job_id == job.id)),
    }


@router.post("/check", response_model=JobCheck, response_model_exclude_unset=True, responses=answers(write=True))
def check_job(body: Annotated[dict[str, Any], Body()], settings: SettingsDep, db: DatabaseDep) -> dict:
    """Validate a ``POST /api/jobs`` body without queuing it; 200 either way.

    ``{"valid": true, "work", "max_work"}``, or ``{"valid": false, "detail": [...]}`` with every refused field at
    once (docs/api.md's validation shape): the schema's refusals, and the core's of the fields the schema took
    (each field's own rule; the work limit on their product only when every field is right).
    """
    try:
        job = JobCreate.model_validate(body)
    except ValidationError as error:
        raw = [{**item, "loc": ("body", *item["loc"])} for item in error.errors()]
        refused = {item["loc"][0] for item in error.errors() if item["loc"]}
        return {"valid": False, "detail": validation_details(raw, body) + _core_refusals(body, refused, settings, db)}
    try:
        with db.session() as session:  # a saved system as POST /api/jobs reads it
            system, overrides, _ = saved_systems.resolve(session, job.system, job.params)
        spec, _ = submission.experiment(job, system, overrides, settings.job_memory_bytes)
    except ConfigError as error:
        refused = InvalidSpec.from_config_error(error, params=job.params)
        return {"valid": False, "detail": [validation_detail(e.loc, e.field, e.msg) for e in refused.every]}
    except InvalidSpec as refused:
        return {"valid": False, "detail": [validation_detail(e.loc, e.field, e.msg) for e in refused.every]}
    return {"valid": True, "work": spec.work, "max_work": MAX_WORK}


def _core_refusals(body: dict[str, Any], refused: set[Any], settings: Any, db: Any) -> list[dict[str, Any]]:
    """The core's refusals of the fields of ``body`` the schema took (those it ``refused`` left at their defaults)."""
    try:
        job = JobCreate.model_validate({k: v for k, v in body.items() if k not in refused})
        with db.session() as session:
            system, overrides, _ = saved_systems.resolve(session, job.system, job.params)
        submission.experiment(job, system, overrides, settings.job_memory_bytes)
    except (ValidationError, InvalidSpec, WorkLimitError):  # nothing more to say of the fields taken
        return []
    except ConfigError as error:
        return [validation_detail(e.loc, e.field, e.msg)
                for e in InvalidSpec.from_config_error(error, params=job.params).every if e.field not in refused]
    return []
