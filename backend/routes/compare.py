"""``/api/compare``: configurations pooled over several jobs."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query
from fastapi.responses import Response

from backend import analysis
from backend.deps import SessionDep
from backend.errors import BadQuery
from backend.schemas import MAX_COMPARE_JOBS
from mgrao_core import MAX_EPISODES

router = APIRouter(prefix="/api", tags=["compare"])


def parse_ids(text: str) -> list[int]:
    """``"1,2,3"`` as ids, or :class:`BadQuery` naming the field ``jobs``."""
    parts = [p.strip() for p in text.split(",") if p.strip()]
    if not parts:
        raise BadQuery("jobs", "give at least one job id, e.g. jobs=1,2,3")
    if len(parts) > MAX_COMPARE_JOBS:
        raise BadQuery("jobs", f"at most {MAX_COMPARE_JOBS} jobs (got {len(parts)})")
    if not all(p.isdigit() for p in parts):
        raise BadQuery("jobs", f"must be comma-separated job ids (got {text!r})")
    return [int(p) for p in parts]


@router.get("/compare")
def compare(
    session: SessionDep,
    jobs: Annotated[str, Query(max_length=1000, description="Comma-separated job ids.")],
    points: Annotated[int | None, Query(ge=1, le=MAX_EPISODES)] = None,
) -> Response:
    """Configurations (config_hash, algorithm) of succeeded jobs, seeds pooled across jobs."""
    body = analysis.dumps(analysis.compare(session, job_ids=parse_ids(jobs), points=points))
    return Response(body, media_type="application/json")
