"""The FastAPI application factory: routers under ``/api``, error mapping, static dashboard."""

from __future__ import annotations

import importlib.resources
import importlib.util
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles

import mgrao_core
from backend import faults
from backend.db import Database
from backend.errors import BadQuery, Conflict, InvalidSpec, NotFound
from backend.limits import BodyLimit
from backend.routes import compare, health, jobs, systems
from backend.settings import Settings
from mgrao_core import ConfigError


def frontend_dir() -> Path | None:
    """The directory of the ``frontend`` package (the dashboard's files), if installed."""
    try:
        path = Path(str(importlib.resources.files("frontend")))
        if path.is_dir():
            return path
    except (ModuleNotFoundError, NotADirectoryError, TypeError):
        pass
    spec = importlib.util.find_spec("frontend")
    for location in (spec.submodule_search_locations or []) if spec else []:
        if Path(location).is_dir():
            return Path(location)
    fallback = Path(__file__).resolve().parent.parent / "frontend"
    return fallback if fallback.is_dir() else None


def plotly_js() -> Path:
    """plotly.min.js from the installed ``plotly`` package (never a CDN)."""
    return Path(str(importlib.resources.files("plotly") / "package_data" / "plotly.min.js"))


def _validation_detail(loc: list[str | int], field: str, msg: str) -> dict[str, Any]:
    return {"loc": loc, "field": field, "msg": msg, "type": "value_error"}


def validation_details(errors: Sequence[Any]) -> list[dict[str, Any]]:
    """Pydantic errors as docs/api.md's ``{"loc", "field", "msg", "type"}``, one per field.

    Union branches (seeds as a count or a list, parameter values) are folded into the field;
    of several errors on a field, a limit beats a type mismatch.
    """
    best: dict[tuple, dict[str, Any]] = {}
    loc: list[str | int]
    for item in errors:
        raw = list(item.get("loc", ()))
        if item.get("type") == "json_invalid":
            loc, field = ["body"], "body"
        elif len(raw) < 2:
            loc = raw or ["body"]
            field = str(loc[-1])
        elif raw[1] == "params" and len(raw) > 2:
            loc, field = raw[:3], str(raw[2])
        else:
            index = next((p for p in raw[2:] if isinstance(p, int)), None)
            loc = raw[:2] + ([index] if index is not None else [])
            field = str(raw[1]) if index is None else f"{raw[1]}[{index}]"
        key = tuple(loc[:3] if len(raw) > 1 and raw[1] == "params" else loc[:2])
        kind = str(item.get("type", "value_error"))
        entry = {"loc": loc, "field": field, "msg": f"{field}: {item.get('msg', 'invalid')}", "type": kind}
        if key not in best or (best[key]["type"].endswith("_type") and not kind.endswith("_type")):
            best[key] = entry
    return list(best.values())


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
        return JSONResponse({"detail": validation_details(error.errors())}, status_code=422)

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


def create_app(settings: Settings | None = None) -> FastAPI:
    """Build the service: API routers first, then the dashboard's static files at ``/``."""
    settings = settings or Settings()
    db = Database(settings.database_url, settings.db_busy_timeout_s)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        db.migrate()
        yield
        db.dispose()

    app = FastAPI(
        title="MG-RAO experiment service", version=mgrao_core.__version__, lifespan=lifespan,
        description="Submit MG-RAO simulation jobs, follow them and compare their results.",
    )
    app.state.settings = settings
    app.state.db = db
    _install_error_handlers(app)
    faults.install(app)
    for module in (jobs, compare, systems, health):
        app.include_router(module.router)

    @app.get("/vendor/plotly.min.js", include_in_schema=False)
    def vendor_plotly() -> FileResponse:
        return FileResponse(plotly_js(), media_type="text/javascript")

    static = frontend_dir()
    if static is not None:
        app.mount("/", StaticFiles(directory=static, html=True), name="dashboard")
    app.add_middleware(BodyLimit, max_bytes=settings.max_body_bytes)
    return app
