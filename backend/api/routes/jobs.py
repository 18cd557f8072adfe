"""``/api/jobs``: submit, list, read, label, cancel, delete; results and episode export."""

from __future__ import annotations

import json
import math
import re
import unicodedata
from collections.abc import Iterator
from typing import Annotated, Literal

import orjson
from fastapi import APIRouter, Path, Query, Response, status
from fastapi.responses import StreamingResponse
from sqlalchemy import select

from backend import wakeup
from backend.api import submission
from backend.api.deps import Authorized, DatabaseDep, SessionDep, SettingsDep
from backend.api.links import JOB, links
from backend.api.responses import LOCATION, EpisodeRow, Results, Weights, answers
from backend.api.schemas import JobBatch, JobBatchCreate, JobCreate, JobOut, JobPage, JobPatch, Kind, Status, Text
from backend.api.strict_query import StrictQueryRoute
from backend.errors import BadQuery, InvalidSpec
from backend.services import analysis, saved_systems, studies, weights
from backend.services.cache import SharedBuilds
from backend.store import crud, summaries
from backend.store.job_order import SORT_HELP, SORT_PATTERN
from backend.store.models import MAX_JOB_ID, Job
from mgrao_core import MAX_EPISODES, ConfigError
from mgrao_core.params import MAX_AGENTS
from mgrao_core.spec import MAX_SEED_VALUE

router = APIRouter(prefix="/api/jobs", tags=["jobs"], route_class=StrictQueryRoute)
LIST_BUILDS = SharedBuilds()

CONFIG_HASH = re.compile(r"[0-9a-f]{64}")
CONFIG_HASH_HELP = "Only the jobs of this configuration: a job's config_hash (64 lowercase hex digits)."
JobId = Annotated[int, Path(ge=1, le=MAX_JOB_ID, description="A job's id.")]
Points = Annotated[int | None, Query(ge=1, le=MAX_EPISODES, description="Downsample to at most this many points.")]
PctBySeed = Annotated[bool, Query(description="Add each seed's paired % from uniform (pct_by_seed).")]
Seed = Annotated[int | None, Query(ge=0, le=MAX_SEED_VALUE,
                                   description="One of the job's seeds (default: its first stored).")]
ChildOffset = Annotated[int | None, Query(ge=0, le=MAX_AGENTS - 1, description=(
    "The first child of the page (default 0); below the job's n_children and the children whose weights a run "
    "stores."))]
Children = Annotated[int | None, Query(ge=1, le=weights.MAX_CHILDREN_PAGE, description=(
    f"Children in the page (default {weights.CHILDREN_PAGE}; at most {weights.MAX_CHILDREN_PAGE:,}, and "
    f"children x resources x types at most {weights.MAX_WEIGHT_VALUES:,})."))]


@router.post("", status_code=status.HTTP_202_ACCEPTED, response_model=JobOut, dependencies=[Authorized],
             responses=answers(write=True, extra={202: {"description": "Queued.", "headers": LOCATION,
                                                        "links": links(JOB, "/id")}}))
def submit_job(body: JobCreate, db: DatabaseDep, settings: SettingsDep, response: Response) -> dict:
    """Queue an experiment; answers once the job is committed."""
    with db.session() as session:  # a saved system: its base preset and overrides, the body's on top
        system, overrides, saved = saved_systems.resolve(session, body.system, body.params)
    try:
        spec, until = submission.experiment(body, system, overrides, settings.job_memory_bytes)
    except ConfigError as error:
        raise InvalidSpec.from_config_error(error, params=overrides) from None
    tags = [*body.tags, saved_systems.tag(saved)] if saved else body.tags
    db.require_room()
    with db.write() as session:
        job = crud.create_job(session, spec=spec, name=body.name, tags=tags, notes=body.notes, until=until)
        session.flush()
        out = crud.job_dict(job)
    wakeup.wake_workers()  # committed: an idle local worker claims it now, not at its next poll
    response.headers["Location"] = f"/api/jobs/{out['id']}"
    return out


@router.post("/batch", status_code=status.HTTP_202_ACCEPTED, response_model=JobBatch, dependencies=[Authorized],
             responses=answers(write=True, extra={202: {"description": "Queued, every job.",
                                                        "links": links(JOB, "/data/0/id")}}))
def submit_jobs(body: JobBatchCreate, db: DatabaseDep, settings: SettingsDep) -> dict:
    """Queue many experiments in one transaction: all or none; answers once they are committed."""
    specs = []
    for index, item in enumerate(body.jobs):
        try:
            specs.append(submission.experiment(item, item.system, item.params, settings.job_memory_bytes))
        except ConfigError as error:
            invalid = InvalidSpec.from_config_error(error, params=item.params)
            raise InvalidSpec(["body", "jobs", index, *invalid.loc[1:]], f"jobs[{index}].{invalid.field}",
                              f"jobs[{index}]: {invalid.msg}") from None
    db.require_room()
    with db.write() as session:
        ids = crud.create_jobs(session, jobs=[
            {"spec": spec, "until": until, "name": item.name, "tags": item.tags, "notes": item.notes}
            for (spec, until), item in zip(specs, body.jobs, strict=True)])
        rows = {job.id: job for job in session.scalars(select(Job).where(Job.id.in_(ids)))}
        out = [crud.job_dict(rows[job_id]) for job_id in ids]
    wakeup.wake_workers()
    return {"data": out, "count": len(out)}


@router.get("", response_model=JobPage, responses=answers(extra={200: {"description": "A page of jobs.",
                                                                       "links": links(JOB, "/data/0/id")}}))
async def list_jobs(
    db: DatabaseDep,
    status: Status | None = None,
    system: Annotated[Text | None, Query(max_length=32)] = None,
    tag: Annotated[Text | None, Query(max_length=50)] = None,
    q: Annotated[Text | None, Query(max_length=200, description="Text in name, notes or tags.")] = None,
    config_hash: Annotated[Text | None, Query(max_length=64, description=CONFIG_HASH_HELP,
                                              json_schema_extra={"pattern": f"^{CONFIG_HASH.pattern}$"})] = None,
    kind: Annotated[Kind | None, Query(description="Only simulated jobs, or only runs logged from outside.")] = None,
    sort: Annotated[Text, Query(max_length=80, description=SORT_HELP,
                                json_schema_extra={"pattern": SORT_PATTERN})] = "-created_at",
    limit: Annotated[int, Query(ge=1, le=200)] = 50,
    cursor: Annotated[Text | None, Query(max_length=500)] = None,
) -> Response:
    """Jobs matching the filters, one page at a time (keyset pagination), each with its stored summaries.

    Requests for the same page at the same time share one reading of the database that began after
    each of them arrived (:class:`backend.services.cache.SharedBuilds`): 50 clients polling the list cost a
    build or two, not 50, and no answer is older than its request.
    """
    if config_hash is not None and not CONFIG_HASH.fullmatch(config_hash):
        raise BadQuery("config_hash", f"must be 64 lowercase hexadecimal digits (a job's config_hash, e.g. a "
                                      f"system's paper_config_hash in GET /api/systems), got {len(config_hash)} "
                                      "characters" + ("" if len(config_hash) != 64 else " that are not all 0-9a-f"))
    # names and tags are stored in NFC (schemas.Printable): a tag or text typed in NFD finds them too
    tag, q = (None if v is None else unicodedata.normalize("NFC", v) for v in (tag, q))
    listing = {"status": status, "system": system, "tag": tag, "q": q, "sort": sort, "limit": limit, "cursor": cursor,
               "config_hash": config_hash, "kind": kind}

    def build() -> bytes:
        with db.session() as session:
            jobs, next_cursor, total = crud.list_jobs(session, **listing)
            stored = summaries.of_jobs(session, [job["id"] for job in jobs])
        for job in jobs:
            job["summaries"] = stored.get(job["id"], {})
        # orjson: a page's JSON in a tenth of json.dumps's time
        return orjson.dumps({"data": jobs, "next_cursor": next_cursor, "count": total})

    answer = await LIST_BUILDS.get((db, *listing.values()), build)
    return Response(answer, media_type="application/json")


@router.get("/{job_id:int}", response_model=JobOut, responses=answers(found=True, extra={
    200: {"description": "The job.", "links": links(JOB, "/id", without=["read"])}}))
def read_job(job_id: JobId, session: SessionDep) -> dict:
    """One job, with its stored summaries once it succeeded."""
    job = crud.job_dict(crud.get_job(session, job_id=job_id))
    return job | {"summaries": summaries.of_jobs(session, [job_id]).get(job_id, {})}


@router.patch("/{job_id:int}", response_model=JobOut, dependencies=[Authorized],
              responses=answers(write=True, found=True, extra={200: {"description": "Changed.",
                                                                     "links": links(JOB, "/id")}}))
def patch_job(job_id: JobId, body: JobPatch, db: DatabaseDep) -> dict:
    """Change a job's name, tags or notes."""
    with db.write() as session:
        job = crud.update_job(session, job_id=job_id, name=body.name, tags=body.tags, notes=body.notes)
        session.flush()
        return crud.job_dict(job)


@router.post("/{job_id:int}/cancel", response_model=JobOut, dependencies=[Authorized],
             responses=answers(write=True, found=True, conflict=True, extra={
                 200: {"description": "Cancelled.", "links": links(JOB, "/id", without=["cancel"])}}))
def cancel_job(job_id: JobId, db: DatabaseDep) -> dict:
    """Cancel a queued or running job (409 otherwise)."""
    with db.write() as session:
        job = crud.cancel_job(session, job_id=job_id)
        session.flush()
        answer = crud.job_dict(job)
    if answer["study_id"] is not None:
        studies.advance_study_quietly(db, answer["study_id"])  # its trial is cancelled and the study moves on
    return answer


@router.delete("/{job_id:int}", status_code=status.HTTP_204_NO_CONTENT, dependencies=[Authorized],
               responses=answers(write=True, found=True, conflict=True))
def delete_job(job_id: JobId, db: DatabaseDep) -> Response:
    """Delete a job that is not running, with its results (409 if running)."""
    with db.write() as session:
        study_id = session.scalar(select(Job.study_id).where(Job.id == job_id))
        crud.delete_job(session, job_id=job_id)
    if study_id is not None:
        studies.advance_study_quietly(db, study_id)  # its trial fails and the study moves on
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get("/{job_id:int}/results", response_model=Results, responses=answers(found=True, conflict=True))
def job_results(job_id: JobId, session: SessionDep, points: Points = None, include_seeds: bool = False,
                pct_by_seed: PctBySeed = False) -> Response:
    """Per configuration: summary, episode band, mean final weights (and each seed's curve or % from uniform)."""
    head, body = analysis.job_results_parts(session, job_id=job_id, points=points, include_seeds=include_seeds,
                                            pct_by_seed=pct_by_seed)
    return StreamingResponse(_slices(head, body), media_type="application/json",
                             headers={"Content-Length": str(len(head) + len(body) - 1)})


@router.get("/{job_id:int}/weights", response_model=Weights, responses=answers(found=True, conflict=True))
def job_weights(job_id: JobId, session: SessionDep, seed: Seed = None, child_offset: ChildOffset = None,
                children: Children = None) -> Response:
    """Every configuration's final weights for one seed and a page of children (the oracle's too where it ran)."""
    answer = weights.of_seed(session, job_id=job_id, seed=seed, child_offset=child_offset, children=children)
    return Response(analysis.dumps(answer), media_type="application/json")


SLICE_BYTES = 1024**2
EPISODES = {
    "description": "Every stored episode: CSV (the default) or, with format=json, a JSON array.",
    "content": {"text/csv": {"schema": {"type": "string", "description": "job_id,algorithm,seed,episode,utility"}},
                "application/json": {"schema": {"type": "array", "items": EpisodeRow.model_json_schema()}}},
    "headers": {"X-MGRAO-Partial": {"description": "true while the job is not complete (the runs stored so far).",
                                    "schema": {"type": "string", "enum": ["true", "false"]}, "required": True},
                "Content-Disposition": {"description": "attachment; filename=job-ID-episodes.csv or .json",
                                        "schema": {"type": "string"}}},
}


def _slices(head: bytes, body: bytes) -> Iterator[bytes | memoryview]:
    """The head, then the body without its opening brace, a megabyte at a time.

    Views of the (cached) bytes: no answer is copied whole, and a slow reader holds back one slice.
    """
    yield head
    view = memoryview(body)
    for start in range(1, len(body), SLICE_BYTES):
        yield view[start : start + SLICE_BYTES]


@router.get("/{job_id:int}/episodes", response_class=StreamingResponse,
            responses=answers(found=True, conflict=True, extra={200: EPISODES}))
def job_episodes(job_id: JobId, db: DatabaseDep, format: Literal["csv", "json"] = "csv") -> StreamingResponse:
    """Every stored episode utility of the job, streamed as CSV or JSON (partial while it runs)."""
    with db.session() as session:
        job = crud.get_job(session, job_id=job_id)
        stored = analysis.require_runs(session, job)
        partial = job.status != "succeeded" or stored < len(job.config["seeds"]) * len(job.config["algorithms"])

    def csv_lines() -> Iterator[str]:
        yield "job_id,algorithm,seed,episode,utility\n"
        with db.session() as session:
            for algorithm, seed, values in analysis.stored_runs(session, job_id=job_id):
                prefix = f"{job_id},{algorithm},{seed},"
                yield "".join(f"{prefix}{episode},{utility!r}\n" for episode, utility in enumerate(values))

    def json_lines() -> Iterator[str]:
        yield "["
        separator = ""
        with db.session() as session:
            for algorithm, seed, values in analysis.stored_runs(session, job_id=job_id):
                head = json.dumps({"job_id": job_id, "algorithm": algorithm, "seed": seed})[:-1]
                yield separator + ",".join(
                    f'{head}, "episode": {episode}, "utility": {_json_number(utility)}}}'
                    for episode, utility in enumerate(values)
                )
                separator = ","
        yield "]\n"

    media = "text/csv" if format == "csv" else "application/json"
    return StreamingResponse(
        csv_lines() if format == "csv" else json_lines(), media_type=media,
        headers={"Content-Disposition": f'attachment; filename="job-{job_id}-episodes.{format}"',
                 "X-MGRAO-Partial": "true" if partial else "false"},
    )


def _json_number(value: float) -> str:
    return repr(value) if math.isfinite(value) else "null"
