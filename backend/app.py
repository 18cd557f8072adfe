"""The FastAPI application factory: routers under ``/api``, error mapping, docs, dashboard, middleware."""

from __future__ import annotations

from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse

import mgrao_core
from backend import faults
from backend.api_methods import ApiMethods
from backend.apidocs import install_api_docs
from backend.db import Database
from backend.docpages import install_docs
from backend.errors import BadQuery, Conflict, InvalidSpec, NotFound
from backend.limits import BodyLimit
from backend.memory import return_large_blocks
from backend.routes import algorithms, changes, compare, health, jobs, studies, systems
from backend.security import (
    AllowedHosts,
    SameOriginWrites,
    SecurityHeaders,
    TokenRequired,
    allowed_hosts,
    token_sent,
)
from backend.settings import Settings
from backend.static import CompressAssets, frontend_dir, install_static, plotly_js
from backend.studies import StudyDriver
from mgrao_core import ConfigError

__all__ = ["create_app", "frontend_dir", "plotly_js", "validation_details"]


def _validation_detail(loc: list[str | int], field: str, msg: str) -> dict[str, Any]:
    return {"loc": loc, "field": field, "msg": msg, "type": "value_error"}


def validation_details(errors: Sequence[Any], body: Any = None) -> list[dict[str, Any]]:
    """Pydantic errors as docs/api.md's ``{"loc", "field", "msg", "type"}``, one per field.

    Union branches (seeds as a count or a list, parameter values) are folded into the field, and a
    bad key of an object (``params``) is named by the object; of several errors on a field, a rule of
    ours beats a limit, which beats a type mismatch. Inside an object of the ``body`` other than a
    job's ``params`` (a study's ``base``, ``space``, ``objective``) the location follows the body all
    the way down and the field is named as the core names it (``space.learning_rate.values[2]``).
    """
    best: dict[tuple, dict[str, Any]] = {}
    loc: list[str | int]
    if any(item.get("type") != "none_required" for item in errors):  # "or null" branches say nothing more
        errors = [item for item in errors if item.get("type") != "none_required"]
    for item in errors:
        raw = list(item.get("loc", ()))
        if "[key]" in raw:  # a key of an object: named by the object (the key itself may be unprintable)
            raw = raw[: raw.index("[key]") - 1]
        nested = (len(raw) > 2 and raw[0] == "body" and raw[1] != "params" and isinstance(body, dict)
                  and isinstance(body.get(raw[1]), dict))
        if item.get("type") == "json_invalid":
            loc, field = ["body"], "body"
        elif nested:
            path = _body_path(body, raw[1:], missing=item.get("type") == "missing")
            loc = ["body", *path]
            field = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")
        elif len(raw) < 2:
            loc = raw or ["body"]
            field = str(loc[-1])
        elif raw[1] == "params" and len(raw) > 2:
            loc, field = raw[:3], str(raw[2])
        else:
            index = next((p for p in raw[2:] if isinstance(p, int)), None)
            loc = raw[:2] + ([index] if index is not None else [])
            field = str(raw[1]) if index is None else f"{raw[1]}[{index}]"
        key = tuple(loc if nested else loc[:3] if len(raw) > 1 and raw[1] == "params" else loc[:2])
        kind = str(item.get("type", "value_error"))
        entry = {"loc": loc, "field": field, "msg": f"{field}: {item.get('msg', 'invalid')}", "type": kind}
        if key not in best or _rank(kind) > _rank(best[key]["type"]):
            best[key] = entry
    return list(best.values())


def _rank(kind: str) -> int:
    """Which of several errors on one field to show: a rule of ours (NUL), then a limit, then a type mismatch."""
    if kind == "value_error":
        return 2
    return 0 if kind.endswith(("_type", "_parsing")) else 1


def _body_path(body: Any, parts: Sequence[str | int], *, missing: bool) -> list[str | int]:
    """The part of an error's location that is in the body (a union's branch names are not), plus a missing key."""
    path: list[str | int] = []
    node = body
    for part in parts:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        elif missing and part == parts[-1] and isinstance(node, dict):
            pass  # the required key that is not there
        else:
            continue
        path.append(part)
    return path


def _install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(InvalidSpec)
    async def invalid_spec(_request: Request, error: InvalidSpec) -> JSONResponse:
        return JSONResponse({"detail": [_validation_detail(error.loc, error.field, error.msg)]}, status_code=422)

    @app.exception_handler(ConfigError)
    async def config_error(_request: Request, error: ConfigError) -> JSONResponse:
        detail = _validation_detail(["body", error.field], error.field, str(error))
        return JSONResponse({"detail": [detail]}, status_code=422)

    @app.exception_handler(RequestValidationError)
    async def validation_error(_request: Request, error: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": validation_details(error.errors(), error.body)}, status_code=422)

    @app.exception_handler(BadQuery)
    async def bad_query(_request: Request, error: BadQuery) -> JSONResponse:
        detail = _validation_detail(["query", error.field], error.field, str(error))
        return JSONResponse({"detail": [detail]}, status_code=422)

    @app.exception_handler(NotFound)
    async def not_found(_request: Request, error: NotFound) -> JSONResponse:
        return JSONResponse({"detail": str(error)}, status_code=404)

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


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the service: API routers first, then the API docs, libraries and the dashboard at ``/``."""
    settings = settings or Settings()
    db = Database(settings.database_url, settings.db_busy_timeout_s, reserve_bytes=settings.min_free_bytes)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        return_large_blocks()
        db.migrate()
        driver = StudyDriver(db, settings.study_poll_s)
        driver.start()
        yield
        driver.stop()
        db.dispose()

    app = FastAPI(
        title="MG-RAO experiment service", version=mgrao_core.__version__, lifespan=lifespan,
        description="Submit MG-RAO simulation jobs, follow them and compare their results.",
        docs_url=None, redoc_url=None,  # backend/apidocs.py serves /docs from local assets
    )
    app.state.settings = settings
    app.state.db = db
    _install_error_handlers(app)
    faults.install(app)  # first of the middlewares: the innermost
    routers = [module.router for module in (jobs, changes, studies, compare, systems, algorithms, health)]
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
