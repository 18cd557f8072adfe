"""``/api/compare``: configurations pooled over several jobs."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query
from fastapi.responses import Response

from backend.api.deps import SessionDep
from backend.api.paths import API_PREFIX
from backend.api.responses import Comparison, answers
from backend.api.schemas import MAX_COMPARE_JOBS, Text
from backend.errors import BadQuery
from backend.services import analysis
from backend.store.models import MAX_JOB_ID
from mgrao_core import MAX_EPISODES

router = APIRouter(prefix=API_PREFIX, tags=["compare"])


def parse_ids(text: str) -> list[int]:
    """``"1,2,3"`` as ids in [1, MAX_JOB_ID], or :class:`BadQuery` naming the field ``jobs``."""
    parts = [p.strip() for p in text.split(",") if p.strip()]
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


@router.get("/compare", response_model=Comparison, responses=answers(found=True))
def compare(
    session: SessionDep,
    jobs: Annotated[Text, Query(max_length=1000, description="Comma-separated job ids.")],
    points: Annotated[int | None, Query(ge=1, le=MAX_EPISODES)] = None,
) -> Response:
    """Configurations (config_hash, algorithm) of succeeded jobs, seeds pooled across jobs."""
    return Response(analysis.compare_json(session, job_ids=parse_ids(jobs), points=points),
                    media_type="application/json")
