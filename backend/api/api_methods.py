"""ASGI middleware that gives paths under ``/api`` their own 404 and 405, ahead of the dashboard's files.

The dashboard is mounted at ``/`` (:mod:`backend.api.static`) and matches every path, so without this
an ``/api`` path that no route takes, or a method its routes do not take, fell through to the
static files: ``PUT /api/jobs/1/cancel`` answered ``405 Allow: GET, HEAD`` (the files' methods) and
``GET /api/nope`` an HTML 404. Here an ``/api`` path that no API route matches answers 404 JSON,
and a method that the path's routes do not take answers 405 JSON with ``Allow`` listing the
methods they do take (all of them, over the several routes one path may have).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from starlette.routing import BaseRoute, Route
from starlette.types import ASGIApp, Receive, Scope, Send

from backend.api.paths import API_PREFIX, under
from backend.api.security import refuse


class ApiMethods:
    """404 for an unknown ``/api`` path, 405 with the path's ``Allow`` for a method it does not take.

    Args:
        app: the application (or middleware) to call for every other request.
        routes: the routes (full paths) at the time of a request: those of the API's routers and
            any added to the application since (other routes are skipped: the mount at ``/``,
            included routers).
        prefix: the API's path prefix.
        authorised: whether a request may learn which paths and methods exist; one that may not is
            passed on unanswered (with ``MGRAO_PROTECT_READS``, the token check after this answers it
            401, like any ``/api`` request without the token).
    """

    def __init__(self, app: ASGIApp, routes: Callable[[], Iterable[BaseRoute]], prefix: str = API_PREFIX,
                 authorised: Callable[[Scope], bool] | None = None) -> None:
        self.app = app
        self.routes = routes
        self.prefix = prefix
        self.authorised = authorised

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Answer 404/405 for ``/api`` requests no route takes; pass everything else on."""
        path = scope.get("path", "")
        if (scope["type"] != "http" or not under(path, self.prefix)
                or (self.authorised is not None and not self.authorised(scope))):
            await self.app(scope, receive, send)
            return
        allowed = {method for route in self.routes() if isinstance(route, Route) and route.path_regex.match(path)
                   for method in route.methods or ()}
        if scope.get("method") in allowed:
            await self.app(scope, receive, send)
        elif allowed:
            allow = ", ".join(sorted(allowed))
            await refuse(send, 405, f"method {scope.get('method')} not allowed here: use {allow}",
                          [(b"allow", allow.encode())])
        else:
            await refuse(send, 404, "no such API path (see /docs)")

