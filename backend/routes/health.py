"""``/api/health``: is the service up and can it reach its database."""

from __future__ import annotations

from fastapi import APIRouter
from fastapi.responses import JSONResponse
from sqlalchemy import text
from sqlalchemy.exc import SQLAlchemyError

import mgrao_core
from backend import crud
from backend.deps import DatabaseDep
from backend.models import QUEUED, RUNNING
from backend.schemas import Health

router = APIRouter(prefix="/api", tags=["health"])


@router.get("/health", response_model=Health)
def health(db: DatabaseDep) -> JSONResponse:
    """Service status, version, database reachability and queue depth."""
    try:
        with db.session() as session:
            session.execute(text("SELECT 1"))
            counts = crud.count_by_status(session)
    except SQLAlchemyError:
        body = {"status": "error", "version": mgrao_core.__version__, "database": "error", "queued": 0,
                "running": 0}
        return JSONResponse(body, status_code=503)
    return JSONResponse({
        "status": "ok", "version": mgrao_core.__version__, "database": "ok",
        "queued": counts.get(QUEUED, 0), "running": counts.get(RUNNING, 0),
    })
