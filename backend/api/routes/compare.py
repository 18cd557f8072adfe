"""``/api/compare``: stored jobs compared configuration by configuration, and the statistics across systems."""

from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query, Request
from fastapi.responses import Response
from starlette.concurrency import run_in_threadpool

from backend.api.deps import DatabaseDep, SessionDep
from backend.api.paths import API_PREFIX
from backend.api.responses import Comparison, ComparisonStatistics, SampleEfficiency, answers
from backend.api.schemas import MAX_COMPARE_JOBS, Text
from backend.api.strict_query import StrictQueryRoute
from backend.errors import BadQuery
from backend.services import comparison
from backend.services.analysis import dumps
from backend.services.compute_pool import ClientGone, ComputePool
from backend.store.db import Database
from backend.store.models import MAX_JOB_ID
from mgrao_core import MAX_EPISODES, ConfigError
from mgrao_core.statistics.bootstrap import DEFAULT_REPETITIONS, MAX_REPETITIONS
from mgrao_core.statistics.report import render

router = APIRouter(prefix=API_PREFIX, tags=["compare"], route_class=StrictQueryRoute)
JOBS_HELP = "Comma-separated job ids."
MAX_BOOTSTRAP_SEED = 2**32 - 1
CURVE_REPETITIONS = 1000
"""The sample-efficiency curves' bootstrap repetitions unless asked otherwise."""
TEXT_FORMATS = {"csv": "text/csv; charset=utf-8", "latex": "text/x-tex; charset=utf-8",
                "table": "text/plain; charset=utf-8"}
STATISTICS_TEXT = {
    "description": "The statistics (format=json, the default), or rendered: a numeric CSV with the protocol in `#` "
                   "lines (format=csv), a LaTeX table with the protocol as its caption (format=latex), or text "
                   "tables (format=table).",
    "content": {media.split(";")[0]: {"schema": {"type": "string"}} for media in TEXT_FORMATS.values()},
}

JOBS_PATTERN = r"^( *[0-9]* *,)*( *[0-9]+ *)(, *[0-9]* *)*$"
"""What :func:`parse_ids` reads: job ids of the digits 0-9 between commas, spaces around them, empty places
skipped, at least one id. (How many, and in which range, the pattern does not say: 422 beyond.)"""
Jobs = Annotated[Text, Query(max_length=1000, description=JOBS_HELP, json_schema_extra={"pattern": JOBS_PATTERN})]
Repetitions = Annotated[int, Query(ge=1, le=MAX_REPETITIONS, description="Bootstrap repetitions of every interval.")]
BootstrapSeed = Annotated[int, Query(ge=0, le=MAX_BOOTSTRAP_SEED, description="The bootstrap's seed.")]
Aggregate = Annotated[Text | None, Query(
    max_length=1000, description="Comma-separated ids of compared jobs whose worlds stand for their systems in the "
                                 "aggregates, where a system has several worlds among the jobs (docs/statistics.md).",
    json_schema_extra={"pattern": JOBS_PATTERN})]


def parse_ids(text: str) -> list[int]:
    """``"1,2,3"`` as ids in [1, MAX_JOB_ID], or :class:`BadQuery` naming the field ``jobs``."""
    parts = [p.strip(" ") for p in text.split(",") if p.strip(" ")]
    if not parts:
        raise BadQuery("jobs", "give at least one job id, e.g. jobs=1,2,3")
    if len(parts) > MAX_COMPARE_JOBS:
        raise BadQuery("jobs", f"at most {MAX_COMPARE_JOBS} jobs (got {len(parts)})")
    if not all(p.isascii() and p.isdigit() for p in parts):
        raise BadQuery("jobs", f"must be comma-separated job ids, digits 0-9 only (got {text!r})")
    ids = [int(p) for p in parts]
    for job_id in ids:
        if not 1 <= job_id <= MAX_JOB_ID:
            raise BadQuery("jobs", f"job ids must be in [1, {MAX_JOB_ID}] (got {job_id})")
    return ids


def _aggregate(text: str | None) -> list[int]:
    """``aggregate=`` as job ids (none when absent), refused as :func:`parse_ids` refuses, naming ``aggregate``."""
    if text is None:
        return []
    try:
        return parse_ids(text)
    except BadQuery as error:
        raise BadQuery("aggregate", error.message.replace("jobs=", "aggregate=")) from None


@router.get("/compare", response_model=Comparison, responses=answers(found=True))
def compare(
    session: SessionDep,
    jobs: Jobs,
    points: Annotated[int | None, Query(ge=1, le=MAX_EPISODES)] = None,
) -> Response:
    """Configurations of succeeded jobs, seeds pooled across jobs and paired within each world (docs/statistics.md)."""
    return Response(comparison.compare_json(session, job_ids=parse_ids(jobs), points=points),
                    media_type="application/json")


BUSY = {503: {
    "description": "The database cannot be read now, or the statistics are busy: every thread of their pool computes "
                   "and its queue is full (MGRAO_STATS_WORKERS, MGRAO_STATS_QUEUE), or this request waited "
                   "MGRAO_STATS_WAIT_S for its turn. Nothing was computed for it: retry after Retry-After seconds.",
    "headers": {"Retry-After": {"description": "Seconds to wait before retrying.", "schema": {"type": "integer"}}},
    "content": {"application/json": {"schema": {"type": "object", "properties": {"detail": {"type": "string"}}}}},
}}


async def _computed(request: Request, db: Database, pending: comparison.Pending) -> bytes | None:
    """The answer's bytes: kept, or computed in the statistics' pool; None when the client has gone meanwhile."""
    cached = pending.cached()
    if cached is not None:
        return cached

    def compute() -> bytes:
        with db.session() as session:
            return pending.compute(session)

    pool: ComputePool = request.app.state.statistics_pool
    try:
        return await pool.answer(pending.key, compute, gone=request.is_disconnected, what=pending.what)
    except ClientGone:
        return None


def _pending(db: Database, make: Callable[..., comparison.Pending], **query: Any) -> comparison.Pending:
    with db.session() as session:
        return make(session, **query)


CLIENT_GONE = 499
"""The status of an answer nobody reads: its client closed the connection before it was ready (never sent)."""


@router.get("/compare/statistics", response_model=ComparisonStatistics,
            responses=answers(found=True, extra={200: STATISTICS_TEXT} | BUSY))
async def statistics(
    request: Request,
    db: DatabaseDep,
    jobs: Jobs,
    reps: Repetitions = DEFAULT_REPETITIONS,
    seed: BootstrapSeed = 0,
    format: Literal["json", "csv", "latex", "table"] = "json",
    aggregate: Aggregate = None,
) -> Response:
    """Scores, aggregates across systems, performance profiles, P(X > Y) and paired tests of the configurations.

    Computed in a pool of threads of its own, bounded (docs/service.md, "Statistics under load"): 503 with
    ``Retry-After`` when it is full; the same request again is answered from the kept answer.
    """
    ids = parse_ids(jobs)
    try:
        pending = await run_in_threadpool(_pending, db, comparison.pending_statistics, job_ids=ids, repetitions=reps,
                                          seed=seed, aggregate=_aggregate(aggregate))
        body = await _computed(request, db, pending)
    except ConfigError as error:
        raise BadQuery(error.field, error.message) from None
    if body is None:
        return Response(status_code=CLIENT_GONE)

    def respond() -> Response:
        answer = pending.answer(body)
        if format == "json":
            return Response(dumps(answer), media_type="application/json")
        extension = {"csv": "csv", "latex": "tex", "table": "txt"}[format]
        return Response(render(answer, format), media_type=TEXT_FORMATS[format],
                        headers={"Content-Disposition": f'inline; filename="compare-statistics.{extension}"'})

    return await run_in_threadpool(respond)


@router.get("/compare/sample-efficiency", response_model=SampleEfficiency,
            responses=answers(found=True, extra=BUSY))
async def sample_efficiency(
    request: Request,
    db: DatabaseDep,
    jobs: Jobs,
    points: Annotated[int, Query(ge=2, le=comparison.MAX_CURVE_POINTS,
                                 description="Buckets of episodes per curve.")] = comparison.MAX_CURVE_POINTS,
    reps: Repetitions = CURVE_REPETITIONS,
    seed: BootstrapSeed = 0,
    aggregate: Aggregate = None,
) -> Response:
    """IQM of the scores per bucket of episodes, with 95% stratified bootstrap bands (sample-efficiency curves).

    Computed in the statistics' pool, as ``/compare/statistics`` is.
    """
    ids = parse_ids(jobs)
    try:
        pending = await run_in_threadpool(_pending, db, comparison.pending_sample_efficiency, job_ids=ids,
                                          points=points, repetitions=reps, seed=seed,
                                          aggregate=_aggregate(aggregate))
        body = await _computed(request, db, pending)
    except ConfigError as error:
        raise BadQuery(error.field, error.message) from None
    if body is None:
        return Response(status_code=CLIENT_GONE)
    return await run_in_threadpool(lambda: Response(dumps(pending.answer(body)), media_type="application/json"))
