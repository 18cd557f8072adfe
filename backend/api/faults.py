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
from sqlalchemy.exc import DBAPIError, InterfaceError, InternalError, OperationalError
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from backend.store.dialect import DatabaseUnavailable, reason

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

    @app.exception_handler(OperationalError)
    @app.exception_handler(InterfaceError)
    @app.exception_handler(InternalError)
    async def database_error(request: Request, error: DBAPIError) -> JSONResponse:
        # what the database reports about itself (unreachable, read-only, locked, missing tables);
        # a malformed statement or argument is a bug, answered 500 by UnexpectedErrors
        log.warning("%s %s: database error: %s", request.method, request.url.path, reason(error))
        return database_unavailable(request, reason(error))

    app.add_middleware(UnexpectedErrors)


class UnexpectedErrors:
    """Any other exception: a JSON 500, logged with its traceback (never Starlette's plain text).

    Installed as the innermost middleware, so the answer still passes the outer ones (security
    headers) and the connection stays usable.
    """

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass the request on; answer 500 if it raises before its answer started."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        started = False

        async def tracking_send(message: Message) -> None:
            nonlocal started
            if message["type"] == "http.response.start":
                started = True
            await send(message)

        try:
            await self.app(scope, receive, tracking_send)
        except Exception as error:
            log.exception("%s %s failed", scope.get("method"), scope.get("path"))
            if started:
                raise
            response = JSONResponse({"detail": f"internal error ({type(error).__name__}); see the service log"},
                                    status_code=500)
            await response(scope, receive, send)
