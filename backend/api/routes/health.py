"""``/api/health``: is the service up and can it reach its database."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse
from sqlalchemy.exc import SQLAlchemyError

import mgrao_core
from backend.api.deps import DatabaseDep, SettingsDep
from backend.api.faults import RETRY_AFTER_S
from backend.api.paths import API_PREFIX
from backend.api.responses import UNAVAILABLE, answers
from backend.api.schemas import Health
from backend.api.strict_query import StrictQueryRoute
from backend.execution import presence
from backend.store import crud
from backend.store.dialect import DatabaseUnavailable, reason
from backend.store.models import QUEUED, RUNNING

router = APIRouter(prefix=API_PREFIX, tags=["health"], route_class=StrictQueryRoute)


@router.get("/health", response_model=Health, responses=answers(extra={503: {
    "description": "The database cannot be written now: status error, the reason in database.", "model": Health,
    "headers": UNAVAILABLE["headers"]}}))
def health(db: DatabaseDep, settings: SettingsDep) -> JSONResponse:
    """Service status, version, whether the database can be written now, queue depth and workers.

    ``workers`` counts the worker processes seen within ``stale_after_s`` by state: ``warming``
    (loading or compiling the simulation kernel) or ``ready``.

    The database check is what a submission needs: room on the SQLite file's disk (at least
    ``MGRAO_MIN_FREE_MIB`` free) and a write transaction on a fresh connection, rolled back, on the
    file the service was configured with. 503 with the reason otherwise; the queue's counts and the
    workers are then unknown (null).
    """
    try:
        db.probe()
        with db.session() as session:
            counts = crud.count_by_status(session)
            workers = presence.counts(session, stale_after_s=settings.stale_after_s)
    except (DatabaseUnavailable, SQLAlchemyError) as error:
        why = str(error) if isinstance(error, DatabaseUnavailable) else reason(error)
        body = {"status": "error", "version": mgrao_core.__version__, "database": why, "queued": None,
                "running": None, "workers": None}
        return JSONResponse(body, status_code=503, headers={"Retry-After": str(RETRY_AFTER_S)})
    return JSONResponse({
        "status": "ok", "version": mgrao_core.__version__, "database": "ok",
        "queued": counts.get(QUEUED, 0), "running": counts.get(RUNNING, 0), "workers": workers,
    })
