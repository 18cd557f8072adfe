"""Browser-facing protections: allowed Host headers, same-origin writes, security headers, protected reads.

Three ASGI middlewares, applied to every HTTP request of the service (API, dashboard, docs), and a
fourth with ``MGRAO_PROTECT_READS``:

* :class:`AllowedHosts` answers 400 to a ``Host`` header that is not one of the configured hosts
  (``MGRAO_ALLOWED_HOSTS``), which defeats DNS rebinding: a page of another site whose name was
  made to resolve to 127.0.0.1 still sends its own name as ``Host``.
* :class:`SameOriginWrites` refuses cross-site writes under ``/api`` (CSRF): a mutating request
  whose ``Origin`` is not the server's own answers 403; one without ``Origin`` must say
  ``Content-Type: application/json`` (415 otherwise), which a page of another site cannot send
  without a CORS preflight that this server never grants.
* :class:`SecurityHeaders` adds the Content-Security-Policy and its companions to every response.
* :class:`TokenRequired` (only with ``MGRAO_PROTECT_READS=true``) answers 401 to any request under
  ``/api``, for ``/openapi.json`` or ``/docs`` without the bearer token, reads included;
  ``/api/health`` answers everyone, but only its status to those without the token.
"""

from __future__ import annotations

import json
import secrets
from collections.abc import Callable, Iterable
from urllib.parse import urlsplit

from fastapi.security.utils import get_authorization_scheme_param
from starlette.datastructures import Headers, MutableHeaders
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from backend.api.paths import API_PREFIX, under

WRITE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})
DEFAULT_PORTS = {"http": 80, "https": 443, "ws": 80, "wss": 443}
WILDCARD_BINDS = frozenset({"", "0.0.0.0", "::"})

CONTENT_SECURITY_POLICY = "; ".join([
    "default-src 'self'",
    "script-src 'self'",  # no inline script, no eval: plotly.js and Swagger UI run without
    "style-src 'self' 'unsafe-inline'",  # plotly.js and Swagger UI set inline styles
    "img-src 'self' data: blob:",  # plot export (PNG as data:/blob: URLs), inline SVG icons
    "font-src 'self' data:",
    "connect-src 'self'",
    "object-src 'none'",
    "base-uri 'none'",
    "form-action 'self'",
    "frame-ancestors 'none'",
])
SECURITY_HEADERS = {
    "content-security-policy": CONTENT_SECURITY_POLICY,
    "x-content-type-options": "nosniff",
    "referrer-policy": "no-referrer",
    "x-frame-options": "DENY",
    "cross-origin-resource-policy": "same-origin",
}


def _normal_host(name: str) -> str:
    """A host name as compared: lower case, no IPv6 brackets, no trailing dot."""
    return name.strip().lower().removeprefix("[").removesuffix("]").removesuffix(".")


def split_host(value: str) -> tuple[str, int | None]:
    """``Host``-style ``name[:port]`` (IPv6 in brackets) as (normalised name, port or None).

    Raises:
        ValueError: the value is not of that form.
    """
    value = value.strip()
    if value.startswith("["):
        name, bracket, rest = value[1:].partition("]")
        if not bracket or (rest and not rest.startswith(":")):
            raise ValueError(value)
        port_text = rest[1:] if rest else None
    else:
        name, colon, port_text = value.rpartition(":")
        if not colon:
            name, port_text = value, None
    if port_text is not None and not (port_text.isascii() and port_text.isdigit() and int(port_text) <= 65535):
        raise ValueError(value)
    if not name or any(c in name for c in "/@?#\\ "):
        raise ValueError(value)
    return _normal_host(name), None if port_text is None else int(port_text)


def allowed_hosts(configured: Iterable[str], bind_host: str = "") -> frozenset[str]:
    """The configured host names plus the address the server binds to (unless it binds everywhere)."""
    hosts = {_normal_host(h) for h in configured if h.strip()}
    if bind_host.strip() not in WILDCARD_BINDS:
        hosts.add(_normal_host(bind_host))
    return frozenset(hosts)


async def refuse(send: Send, status: int, detail: str, headers: Iterable[tuple[bytes, bytes]] = ()) -> None:
    """Answer ``{"detail": detail}`` as JSON with ``status`` (and ``headers``), without calling the app."""
    body = json.dumps({"detail": detail}).encode()
    await send({"type": "http.response.start", "status": status,
                "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
                            *headers]})
    await send({"type": "http.response.body", "body": body})


class AllowedHosts:
    """Answer 400 unless the request's ``Host`` names one of ``hosts`` (any port; ``"*"`` allows any)."""

    def __init__(self, app: ASGIApp, hosts: Iterable[str]) -> None:
        self.app = app
        self.hosts = frozenset(hosts)
        self.any = "*" in self.hosts

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Check the Host header of HTTP requests."""
        if scope["type"] != "http" or self.any:
            await self.app(scope, receive, send)
            return
        value = Headers(scope=scope).get("host", "")
        try:
            name, _port = split_host(value)
        except ValueError:
            name = ""
        if name not in self.hosts:
            shown = value[:100]
            await refuse(send, 400, f"Host header {shown!r} is not allowed: this server answers only to the "
                                     "hosts in MGRAO_ALLOWED_HOSTS")
            return
        await self.app(scope, receive, send)


def own_origin(scope: Scope) -> tuple[str, str, int] | None:
    """(scheme, host, port) of the server as the request addressed it, from its Host header."""
    scheme = scope.get("scheme", "http")
    try:
        name, port = split_host(Headers(scope=scope).get("host", ""))
    except ValueError:
        return None
    return scheme, name, port if port is not None else DEFAULT_PORTS.get(scheme, 80)


def parse_origin(value: str) -> tuple[str, str, int] | None:
    """(scheme, host, port) of an ``Origin`` header, or None for ``null`` and malformed values."""
    try:
        parts = urlsplit(value.strip())
        port = parts.port
    except ValueError:
        return None
    if parts.scheme not in DEFAULT_PORTS or not parts.hostname or parts.path not in ("", "/") or parts.query:
        return None
    return parts.scheme, _normal_host(parts.hostname), port if port is not None else DEFAULT_PORTS[parts.scheme]


class SameOriginWrites:
    """Refuse cross-site writes under ``/api``: 403 for a foreign ``Origin``, 415 for a non-JSON body.

    A mutating request (POST, PUT, PATCH, DELETE) passes when its ``Origin`` is the server's own,
    or when it has no ``Origin`` and its ``Content-Type`` is ``application/json`` (even with no body).
    """

    def __init__(self, app: ASGIApp, prefix: str = API_PREFIX) -> None:
        self.app = app
        self.prefix = prefix

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Check Origin and Content-Type of mutating API requests."""
        path = scope.get("path", "")
        if (scope["type"] != "http" or scope.get("method") not in WRITE_METHODS
                or not under(path, self.prefix)):
            await self.app(scope, receive, send)
            return
        headers = Headers(scope=scope)
        origin = headers.get("origin")
        if origin is not None:
            mine = own_origin(scope)
            if mine is None or parse_origin(origin) != mine:
                await refuse(send, 403, f"cross-origin request refused: Origin {origin[:100]!r} is not this "
                                         "server's origin")
                return
        else:
            media_type = headers.get("content-type", "").partition(";")[0].strip().lower()
            if media_type != "application/json":
                shown = headers.get("content-type", "none")[:100]
                await refuse(send, 415, "requests that change data need Content-Type: application/json, even "
                                         f"without a body (got {shown!r})")
                return
        await self.app(scope, receive, send)


class SecurityHeaders:
    """Add :data:`SECURITY_HEADERS` to every HTTP response (a header the app set itself is kept)."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Add the headers at the start of the response."""
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                message.setdefault("headers", [])
                headers = MutableHeaders(scope=message)
                for name, value in SECURITY_HEADERS.items():
                    if name not in headers:
                        headers[name] = value
            await send(message)

        await self.app(scope, receive, send_with_headers)


def bearer_matches(authorization: str | None, token: str) -> bool:
    """Whether an ``Authorization`` header is ``Bearer <token>`` (scheme in any case; constant-time compare).

    Read as FastAPI's ``HTTPBearer`` reads it, so that the routes' own check (``backend.api.deps``) and
    :class:`TokenRequired` accept the same headers.
    """
    scheme, given = get_authorization_scheme_param(authorization)
    if not (authorization and scheme and given) or scheme.lower() != "bearer":
        return False
    return secrets.compare_digest(given.encode(), token.encode())


def token_sent(token: str) -> Callable[[Scope], bool]:
    """Whether a request carries ``Authorization: Bearer <token>``."""
    return lambda scope: bearer_matches(Headers(scope=scope).get("authorization"), token)


class TokenRequired:
    """401 without the bearer token for every request under ``prefix`` and for ``paths``; ``health`` says less.

    Runs inside :class:`BodyLimit`, so a write is refused for its origin, content type or size (403,
    415, 413) as without this middleware, then here for its token: before FastAPI reads its body. The
    write routes keep their own check (``backend.api.deps.Authorized``). A GET of ``health`` passes
    without the token, and its answer is cut to ``{"status": ...}`` with the same status code (and
    ``Retry-After``): nothing about the queue, the workers or the database.
    """

    def __init__(self, app: ASGIApp, token: str, paths: Iterable[str], prefix: str = API_PREFIX,
                 health: str = API_PREFIX + "/health") -> None:
        if not token:
            raise ValueError("TokenRequired needs a token")
        self.app = app
        self.token = token
        self.paths = frozenset(paths)
        self.prefix = prefix
        self.health = health

    def guarded(self, path: str) -> bool:
        """Whether ``path`` needs the token."""
        return under(path, self.prefix) or path in self.paths

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Pass a request with the token, or one for a path that holds no data; refuse the others."""
        path = scope.get("path", "")
        if (scope["type"] != "http" or not self.guarded(path)
                or bearer_matches(Headers(scope=scope).get("authorization"), self.token)):
            await self.app(scope, receive, send)
            return
        if path == self.health and scope.get("method") == "GET":
            await self.app(scope, receive, _status_only(send))
            return
        await refuse(send, 401, "missing or wrong bearer token: this server's data, reads included, needs "
                                 "Authorization: Bearer <MGRAO_API_TOKEN>", headers=[(b"www-authenticate", b"Bearer")])


def _status_only(send: Send) -> Send:
    """A ``send`` that turns a health answer into ``{"status": ...}``, keeping its code and ``Retry-After``."""
    start: Message = {}
    chunks: list[bytes] = []

    async def reduced(message: Message) -> None:
        if message["type"] == "http.response.start":
            start.update(message)
            return
        if message["type"] != "http.response.body":
            await send(message)
            return
        chunks.append(message.get("body", b""))
        if message.get("more_body", False):
            return
        code = start.get("status", 500)
        try:
            said = json.loads(b"".join(chunks)).get("status")
        except (ValueError, AttributeError):
            said = None
        status = said if said in ("ok", "error") else ("ok" if code < 400 else "error")
        body = json.dumps({"status": status}).encode()
        headers = [(b"content-type", b"application/json"), (b"content-length", str(len(body)).encode())]
        headers += [(k, v) for k, v in start.get("headers", []) if k.lower() == b"retry-after"]
        await send({"type": "http.response.start", "status": code, "headers": headers})
        await send({"type": "http.response.body", "body": body})

    return reduced
