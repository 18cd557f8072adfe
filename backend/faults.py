"""How the service answers when something below it fails: 503 for the database, JSON 500 otherwise.

A request that cannot reach or write the database is answered 503 with the reason and a
``Retry-After``, and nothing of it was changed (a submission that could not be stored was not
queued). Any other unexpected error is answered 500 as JSON (never Starlette's plain text), and
logged with its traceback.
"""

from __future__ import annotations

import logging

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse
from sqlalchemy.exc import SQLAlchemyError

from backend.dialect import DatabaseUnavailable, reason

log = logging.getLogger("mgrao.api")
RETRY_AFTER_S = 5


def database_unavailable(request: Request, why: str) -> JSONResponse:
    """The 503 answer, naming what was not done."""
    if request.method == "POST" and request.url.path.rstrip("/") == "/api/jobs":
        message = f"the job could not be stored, so it was not queued: database unavailable ({why})"
    elif request.method in ("POST", "PATCH", "PUT", "DELETE"):
        message = f"nothing was changed: database unavailable ({why})"
    else:
        message = f"database unavailable ({why})"
    return JSONResponse({"detail": message}, status_code=503, headers={"Retry-After": str(RETRY_AFTER_S)})


def install(app: FastAPI) -> None:
    """Register the handlers on ``app``."""

    @app.exception_handler(DatabaseUnavailable)
    async def unavailable(request: Request, error: DatabaseUnavailable) -> JSONResponse:
        return database_unavailable(request, str(error))

    @app.exception_handler(SQLAlchemyError)
    async def database_error(request: Request, error: SQLAlchemyError) -> JSONResponse:
        log.warning("%s %s: database error: %s", request.method, request.url.path, reason(error))
        return database_unavailable(request, reason(error))

    @app.exception_handler(Exception)
    async def unexpected(request: Request, error: Exception) -> JSONResponse:
        log.exception("%s %s failed", request.method, request.url.path)
        return JSONResponse({"detail": f"internal error ({type(error).__name__}); see the service log"},
                            status_code=500)
