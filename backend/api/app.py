"""The FastAPI application factory: routers under ``/api``, error mapping, docs, dashboard, middleware."""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

import mgrao_core
from backend.api import faults
from backend.api.api_methods import ApiMethods
from backend.api.apidocs import install_api_docs
from backend.api.docpages import install_docs
from backend.api.limits import BodyLimit
from backend.api.routes import algorithms, changes, compare, external, health, jobs, studies, systems
from backend.api.security import (
    AllowedHosts,
    SameOriginWrites,
    SecurityHeaders,
    TokenRequired,
    allowed_hosts,
    token_sent,
)
from backend.api.static import CompressAssets, frontend_dir, install_static, plotly_js
from backend.api.validation import validation_detail, validation_details
from backend.errors import BadQuery, Busy, Conflict, InvalidSpec, NotFound
from backend.services.compute_pool import ComputePool
from backend.services.memory import return_large_blocks
from backend.services.studies import StudyDriver
from backend.settings import Settings
from backend.store.db import Database
from mgrao_core import ConfigError

__all__ = ["create_app", "frontend_dir", "plotly_js"]


def _install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(InvalidSpec)
    async def invalid_spec(_request: Request, error: InvalidSpec) -> JSONResponse:
        return JSONResponse({"detail": [validation_detail(e.loc, e.field, e.msg) for e in error.every]},
                            status_code=422)

    @app.exception_handler(ConfigError)
    async def config_error(_request: Request, error: ConfigError) -> JSONResponse:
        every = getattr(error, "errors", (error,))
        return JSONResponse({"detail": [validation_detail(["body", e.field], e.field, str(e)) for e in every]},
                            status_code=422)

    @app.exception_handler(RequestValidationError)
    async def validation_error(_request: Request, error: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": validation_details(error.errors(), error.body)}, status_code=422)

    @app.exception_handler(BadQuery)
    async def bad_query(_request: Request, error: BadQuery) -> JSONResponse:
        detail = validation_detail(["query", error.field], error.field, str(error))
        return JSONResponse({"detail": [detail]}, status_code=422)

    @app.exception_handler(NotFound)
    async def not_found(_request: Request, error: NotFound) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=404)

    @app.exception_handler(Busy)
    async def busy(_request: Request, error: Busy) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=503,
                            headers={"Retry-After": str(error.retry_after_s)})

    @app.exception_handler(Conflict)
    async def conflict(_request: Request, error: Conflict) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=409)


def _describe_token(app: FastAPI, required: bool) -> None:
    """The OpenAPI document's writes ask for the bearer token only when the service has one.

    Without ``MGRAO_API_TOKEN`` a write needs none (its security lists no requirement, ``{}``, first).
    """
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            document = generate()
            for operations in document["paths"].values():
                for operation in operations.values():
                    if "security" in operation and not required:
                        operation["security"] = [{}, *operation["security"]]
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]


def _api_log_lines() -> None:
    """The API's own log lines (``mgrao.api``, INFO and up) on stderr, where nothing configured logging already.

    (Without this only its warnings would reach stderr, through logging's last resort.) A process that sets up
    logging itself, e.g. a test run, keeps its own.
    """
    logger = logging.getLogger("mgrao.api")
    if logger.handlers or logging.getLogger().handlers:
        return
    handler = logging.StreamHandler()
    handler.setFormatter(logging.Formatter("%(asctime)s %(name)s %(levelname)s %(message)s"))
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the service: API routers first, then the API docs, libraries and the dashboard at ``/``."""
    settings = settings or Settings()
    db = Database(settings.database_url, settings.db_busy_timeout_s, reserve_bytes=settings.min_free_bytes)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        return_large_blocks()
        _api_log_lines()
        db.migrate()
        driver = StudyDriver(db, settings.study_poll_s)
        driver.start()
        app.state.statistics_pool = ComputePool(  # docs/service.md, "Statistics under load"
            workers=settings.stats_workers, queue=settings.stats_queue, retry_after_s=settings.stats_retry_after_s,
            wait_s=settings.stats_wait_s, name="statistics")
        yield
        driver.stop()
        app.state.statistics_pool.close()
        db.dispose()

    app = FastAPI(
        title="MG-RAO experiment service", version=mgrao_core.__version__, lifespan=lifespan,
        description="Submit MG-RAO simulation jobs, follow them and compare their results.",
        docs_url=None, redoc_url=None,  # backend/api/apidocs.py serves /docs from local assets
    )
    app.state.settings = settings
    app.state.db = db
    _install_error_handlers(app)
    faults.install(app)  # first of the middlewares: the innermost
    routers = [module.router for module in (jobs, changes, external, studies, compare, systems, algorithms, health)]
    for router in routers:
        app.include_router(router)

    _describe_token(app, required=bool(settings.api_token))
    install_api_docs(app)
    install_docs(app)  # the project's docs/ as HTML pages under /project-docs/
    install_static(app)  # last: the dashboard is mounted at "/"

    # add_middleware wraps: the last added runs first. Order of a request: security headers on
    # whatever answers, Host check (400), an /api path or method no route takes (404/405, before
    # the dashboard's mount at "/" would answer it), same-origin writes (403/415), body limit (413),
    # with MGRAO_PROTECT_READS the token for /api, the API schema and docs (401), gzip of browser files
    # when the client accepts it (text of 1000 bytes or more, not /api), the app.
    app.add_middleware(CompressAssets, minimum_size=1000, compresslevel=6)
    if settings.protect_reads:
        app.add_middleware(TokenRequired, token=settings.api_token,
                           paths=(app.openapi_url or "/openapi.json", "/docs", "/redoc"))
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    app.add_middleware(SameOriginWrites)
    app.add_middleware(ApiMethods, routes=lambda: [*app.routes, *(route for r in routers for route in r.routes)],
                       authorised=token_sent(settings.api_token) if settings.protect_reads else None)
    app.add_middleware(AllowedHosts, hosts=allowed_hosts(settings.allowed_hosts, settings.host))
    app.add_middleware(SecurityHeaders)
    return app
