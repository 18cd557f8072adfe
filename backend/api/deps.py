"""FastAPI dependencies: settings, database sessions and the bearer token."""

from __future__ import annotations

import secrets
from collections.abc import Iterator
from typing import Annotated, Any

from fastapi import Depends, HTTPException, Request, status
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer
from sqlalchemy.orm import Session

from backend.errors import InvalidSpec
from backend.settings import Settings
from backend.store.db import Database


def get_settings(request: Request) -> Settings:
    """The app's settings."""
    return request.app.state.settings


def get_db(request: Request) -> Database:
    """The app's database."""
    return request.app.state.db


def get_session(db: Annotated[Database, Depends(get_db)]) -> Iterator[Session]:
    """A read session for one request."""
    with db.session() as session:
        yield session


_bearer = HTTPBearer(auto_error=False, description="Required on mutating routes when MGRAO_API_TOKEN is set.")


def require_token(
    settings: Annotated[Settings, Depends(get_settings)],
    credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)],
) -> None:
    """Refuse (401) a mutating request without the right bearer token, when a token is configured."""
    expected = settings.api_token
    if not expected:
        return
    given = credentials.credentials if credentials is not None else ""
    if not secrets.compare_digest(given.encode(), expected.encode()):
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED, "missing or wrong bearer token",
            headers={"WWW-Authenticate": "Bearer"},
        )


def refuse_unknown_query(request: Request) -> None:
    """Refuse (422) a query parameter the operation does not take, each one named.

    Ignored, a misspelt filter (``GET /api/jobs?stauts=running``) would answer every job as if it
    had been applied; every operation's parameters are in the OpenAPI document.
    """
    route = request.scope.get("route")
    if route is None or not request.query_params:
        return
    known = _query_names(route)
    unknown = list(dict.fromkeys(key for key in request.query_params if key not in known))
    if unknown:
        takes = ", ".join(sorted(known)) or "no query parameters"
        first, *rest = (InvalidSpec(["query", key], key, f"{key}: is not a parameter of this operation (it takes "
                                                          f"{takes})") for key in unknown)
        raise InvalidSpec(first.loc, first.field, first.msg, rest)


def _query_names(route: Any) -> frozenset[str]:
    """The query parameters an operation takes (its own and its dependencies'): a few, read in microseconds."""
    def names(dependant: Any) -> set[str]:
        return {p.alias for p in dependant.query_params}.union(*(names(d) for d in dependant.dependencies))
    return frozenset(names(route.dependant))


SettingsDep = Annotated[Settings, Depends(get_settings)]
DatabaseDep = Annotated[Database, Depends(get_db)]
SessionDep = Annotated[Session, Depends(get_session)]
Authorized = Depends(require_token)
