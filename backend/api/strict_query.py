"""Every API operation refuses (422) a query parameter it does not take, named with every other refused field.

Ignored, a misspelt filter (``GET /api/jobs?stauts=running``) would answer every job as if it had been
applied. A request with such a parameter is validated as usual (the token, the path, the other
parameters, the body) by a twin of its operation whose endpoint never runs: the answer names the
unknown parameters beside every field the operation itself refuses (docs/api.md, "Errors"), a missing
token still answers 401 first, and nothing the operation would do happens. A request without one goes
to the operation untouched.
"""

from __future__ import annotations

import inspect
from collections.abc import Awaitable, Callable
from typing import Any

from fastapi import Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from fastapi.routing import APIRoute

from backend.api.validation import validation_detail, validation_details

Handler = Callable[[Request], Awaitable[Response]]


class _Valid(Exception):  # noqa: N818 - not an error: the twin's endpoint reached, every other field taken
    """Raised by a twin's endpoint: the request is valid but for its unknown query parameters."""


class StrictQueryRoute(APIRoute):
    """An operation that refuses the query parameters it does not take: every API router's ``route_class``."""

    def get_route_handler(self) -> Handler:
        """The operation's handler, behind the check of its query parameters."""
        return _strict(self, super().get_route_handler())


def query_names(route: APIRoute) -> frozenset[str]:
    """The query parameters an operation takes: its own and its dependencies'."""
    def names(dependant: Any) -> set[str]:
        return {p.alias for p in dependant.query_params}.union(*(names(d) for d in dependant.dependencies))
    return frozenset(names(route.dependant))


def _strict(route: APIRoute, handler: Handler) -> Handler:
    known = query_names(route)
    twin: list[Handler] = []  # built at the first request that needs it

    async def strict(request: Request) -> Response:
        unknown = list(dict.fromkeys(key for key in request.query_params if key not in known))
        if not unknown:
            return await handler(request)
        takes = ", ".join(sorted(known)) or "no query parameters"
        refused = [validation_detail(["query", key], key, f"{key or '(a parameter without a name)'}: is not a "
                                                          f"parameter of this operation (it takes {takes})")
                   for key in unknown]
        if not twin:
            twin.append(_twin(route).get_route_handler())
        try:
            await twin[0](request)
        except RequestValidationError as error:
            refused += validation_details(error.errors(), error.body)
        except _Valid:
            pass
        return JSONResponse({"detail": refused}, status_code=422)

    return strict


def _twin(route: APIRoute) -> APIRoute:
    """The operation with the same parameters, body and dependencies, whose endpoint only says it was reached."""
    def reached(**_: Any) -> None:
        raise _Valid
    # the endpoint's parameters with their annotations evaluated, as FastAPI reads them
    reached.__signature__ = inspect.signature(route.endpoint, eval_str=True).replace(  # type: ignore[attr-defined]
        return_annotation=inspect.Signature.empty)
    return APIRoute(route.path, reached, methods=route.methods, dependencies=route.dependencies)
