"""The browser files the service serves: the dashboard, and libraries from installed packages.

* The dashboard (the ``frontend`` package): ``index.html`` is revalidated on every use
  (``Cache-Control: no-cache`` with an ETag), so an upgrade shows at the next load. It names the
  dashboard's modules and style sheet under ``/v/<digest>/``, the digest being that of every file
  they are built from (:func:`dashboard_digest`); there they are cached for a year (``immutable``),
  so a full reload asks the server for the page and its data alone, while a changed file changes
  the digest and so every address. Relative imports between modules stay inside ``/v/<digest>/``.
  The same files stay at their plain addresses (``/js/app.js``), revalidated on every use.
  ``index.html`` is served with the versioned plotly.js address filled in.
* Libraries (plotly.js, Swagger UI from ``fastapi-offline``) live under addresses that carry
  their version and are cached for a year (``immutable``); each is gzip-compressed once, in memory,
  for the clients that accept gzip. Every file answers HEAD.
* plotly.js is the dashboard's partial bundle (``frontend/vendor/plotly-dashboard.min.js``: the
  trace types the dashboard draws, a quarter of the full bundle's bytes, built from npm's plotly.js
  by ``tools/plotly-bundle/build.sh``) when it was built from the plotly.js version that the
  installed ``plotly`` package ships; otherwise that package's full bundle, with a warning.
"""

from __future__ import annotations

import fnmatch
import gzip
import hashlib
import importlib.metadata
import importlib.resources
import importlib.util
import json
import logging
import mimetypes
from dataclasses import dataclass
from functools import cache, cached_property
from pathlib import Path

from fastapi import FastAPI, Request, Response
from fastapi.responses import RedirectResponse
from starlette.middleware.gzip import GZipMiddleware
from starlette.types import Receive, Scope, Send

from backend.api.paths import under

IMMUTABLE = "public, max-age=31536000, immutable"
REVALIDATE = "no-cache"
PLOTLY_ALIAS = "/vendor/plotly.min.js"
HTML_PLACEHOLDER = f'href="{PLOTLY_ALIAS}"'
log = logging.getLogger("mgrao.api")


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


def full_plotly_js() -> Path:
    """plotly.min.js, every trace type, from the installed ``plotly`` package (never a CDN)."""
    return Path(str(importlib.resources.files("plotly") / "package_data" / "plotly.min.js"))


@dataclass(frozen=True)
class PlotlyBuild:
    """The plotly.js the dashboard gets: its file, its versioned address, the trace types it draws."""

    path: Path
    url: str
    traces: tuple[str, ...] | None
    """The trace types it registers; None for the full bundle (all of them)."""


def _partial_bundle(version: str) -> PlotlyBuild | None:
    """The dashboard's partial bundle if it is installed whole and was built from plotly.js ``version``."""
    static = frontend_dir()
    if static is None:
        return None
    script, manifest_file = static / "vendor" / "plotly-dashboard.min.js", static / "vendor" / "plotly-dashboard.json"
    try:
        manifest = json.loads(manifest_file.read_text(encoding="utf-8"))
        digest = hashlib.sha256(script.read_bytes()).hexdigest()
    except (OSError, ValueError):
        return None
    if manifest.get("sha256") != digest:
        log.warning("%s does not match its manifest (sha256); serving the plotly package's full plotly.js", script)
        return None
    if manifest.get("plotly_js") != version:
        log.warning("the dashboard's plotly.js bundle was built from plotly.js %s but the installed plotly package "
                    "ships %s: serving the package's full bundle (rebuild with tools/plotly-bundle/build.sh, or "
                    "install the plotly version pyproject.toml pins)", manifest.get("plotly_js"), version)
        return None
    return PlotlyBuild(script, f"/vendor/plotly-dashboard-{version}-{digest[:12]}.min.js", tuple(manifest["traces"]))


@cache
def plotly_build() -> PlotlyBuild:
    """The partial bundle when it matches the installed plotly.js version, else the full bundle."""
    from plotly.offline import get_plotlyjs_version

    version = get_plotlyjs_version()
    return _partial_bundle(version) or PlotlyBuild(full_plotly_js(), f"/vendor/plotly-{version}.min.js", None)


def plotly_js() -> Path:
    """The file of the plotly.js the dashboard is served (:func:`plotly_build`)."""
    return plotly_build().path


def plotly_url() -> str:
    """Its versioned address, e.g. ``/vendor/plotly-dashboard-4.1.1-<sha256 prefix>.min.js``."""
    return plotly_build().url


def docs_assets_dir() -> Path:
    """Swagger UI's files, shipped by the ``fastapi-offline`` package."""
    return Path(str(importlib.resources.files("fastapi_offline") / "static"))


@cache
def docs_asset_url(name: str) -> str:
    """The versioned address of one of :func:`docs_assets_dir`'s files."""
    return f"/vendor/docs-{importlib.metadata.version('fastapi-offline')}/{name}"


DOCS_ASSETS = {"swagger-ui-bundle.js": "text/javascript", "swagger-ui.css": "text/css"}


def accepts_gzip(request: Request) -> bool:
    """Whether the request's Accept-Encoding admits gzip (by name or ``*``, with a q above 0)."""
    for part in request.headers.get("accept-encoding", "").split(","):
        coding, *params = (p.strip().lower() for p in part.split(";"))
        if coding in ("gzip", "x-gzip", "*"):
            q = next((p[2:] for p in params if p.startswith("q=")), "1")
            try:
                if float(q) > 0:
                    return True
            except ValueError:
                continue
    return False


@dataclass(frozen=True)
class VendorFile:
    """A library file served under a versioned address: read once, cached for a year, gzip once."""

    body: bytes
    media_type: str

    @classmethod
    def read(cls, path: Path, media_type: str) -> VendorFile:
        """The file as it is now: served as such whatever happens to ``path`` later (a reinstall)."""
        return cls(path.read_bytes(), media_type)

    @cached_property
    def etag(self) -> str:
        """Strong validator of the file's bytes."""
        return '"' + hashlib.sha256(self.body).hexdigest()[:32] + '"'

    @cached_property
    def gzipped(self) -> bytes:
        """The file's bytes, gzip-compressed (level 9, once per process)."""
        return gzip.compress(self.body, compresslevel=9, mtime=0)

    def response(self, request: Request) -> Response:
        """200 (gzip when accepted), 304 for a matching If-None-Match; HEAD answers the headers alone."""
        headers = {"cache-control": IMMUTABLE, "etag": self.etag, "vary": "Accept-Encoding"}
        if self.etag in request.headers.get("if-none-match", ""):
            return Response(status_code=304, headers=headers)
        body = self.body
        if accepts_gzip(request):
            body = self.gzipped
            headers["content-encoding"] = "gzip"
        headers["content-length"] = str(len(body))
        return Response(b"" if request.method == "HEAD" else body, media_type=self.media_type, headers=headers)


@dataclass(frozen=True)
class StaticFile:
    """One of the dashboard's files as the service read it at start."""

    body: bytes
    media_type: str
    etag: str


def snapshot(directory: Path) -> dict[str, StaticFile]:
    """Every file under ``directory`` (but Python's), by its path relative to it, read now.

    The service serves these whatever happens to the installed files later: the README's second install
    (``pip install -e``) removes the first's package under a running ``mgrao serve``, which then answered
    500 on ``/`` and 404 on ``/js/app.js``.
    """
    files = {}
    for path in sorted(directory.rglob("*")):
        if not path.is_file() or "__pycache__" in path.parts or path.suffix in (".py", ".pyc"):
            continue
        relative = path.relative_to(directory).as_posix()
        body = path.read_bytes()
        media_type = mimetypes.guess_type(relative)[0] or "application/octet-stream"
        if media_type.startswith("text/") or media_type in ("application/javascript", "image/svg+xml"):
            media_type += "; charset=utf-8"
        files[relative] = StaticFile(body, media_type, '"' + hashlib.sha256(body).hexdigest()[:32] + '"')
    return files


class SnapshotFiles:
    """An ASGI app answering GET and HEAD with the snapshot's files: ETag, 304, and a cache policy.

    ``versioned``: paths come as ``<digest>/<file>``; a file under the served digest is cached for a year, one
    under another digest (a page loaded before an upgrade) gets the file as it is now, to be revalidated.
    """

    def __init__(self, files: dict[str, StaticFile], *, versioned: str | None = None) -> None:
        self.files, self.versioned = files, versioned

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Serve the file the path names, or 404 (405 for another method)."""
        request = Request(scope)
        path, root = scope["path"], scope.get("root_path", "")
        path = (path[len(root):] if root and path.startswith(root) else path).lstrip("/")  # the path under the mount
        cache = REVALIDATE
        if self.versioned is not None:
            digest, _, path = path.partition("/")
            cache = IMMUTABLE if digest == self.versioned else REVALIDATE
        if request.method not in ("GET", "HEAD"):
            response = Response("Method Not Allowed", status_code=405, headers={"allow": "GET, HEAD"})
        elif path in self.files:
            file = self.files[path]
            headers = {"cache-control": cache, "etag": file.etag}
            if file.etag in request.headers.get("if-none-match", ""):
                response = Response(status_code=304, headers=headers)
            else:
                headers["content-length"] = str(len(file.body))
                response = Response(b"" if request.method == "HEAD" else file.body, headers=headers,
                                    media_type=file.media_type)
        else:
            response = Response("Not Found", status_code=404, media_type="text/plain")
        await response(scope, receive, send)


VERSIONED_FILES = ("js/*.js", "style.css", "favicon.svg")
"""The dashboard's files that ``index.html`` names under ``/v/<digest>/``."""


def dashboard_digest(static: Path | dict[str, StaticFile]) -> str:
    """sha256 (first 16 hex digits) of :data:`VERSIONED_FILES`, by name and content."""
    files = snapshot(static) if isinstance(static, Path) else static
    digest = hashlib.sha256()
    for pattern in VERSIONED_FILES:
        for name in sorted(n for n in files if fnmatch.fnmatchcase(n, pattern) and n.count("/") == pattern.count("/")):
            digest.update(name.encode() + b"\0" + files[name].body + b"\0")
    return digest.hexdigest()[:16]


class CompressAssets(GZipMiddleware):
    """gzip for the browser files when the client accepts it; API answers go out as they are.

    The API is mostly read over the loopback interface, where compressing costs more than it saves.
    """

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        """Compress unless the path is under ``/api/`` or the client's Accept-Encoding refuses gzip."""
        if scope["type"] == "http" and (under(scope.get("path", ""))
                                        or not accepts_gzip(Request(scope))):
            await self.app(scope, receive, send)
            return
        await super().__call__(scope, receive, send)


MODULES_PLACEHOLDER = "<!-- modulepreload -->"


def _module_preloads(files: dict[str, StaticFile], prefix: str) -> str:
    """A ``modulepreload`` link for every ES module of the dashboard.

    The modules import each other three levels deep; without these links the browser finds each
    level only when the one above has arrived (three round trips in a row on a first load, or when
    the versioned addresses are not in use). With them all are asked for at once.
    """
    modules = sorted(n for n in files if n.startswith("js/") and n.endswith(".js") and n.count("/") == 1)
    return "".join(f'<link rel="modulepreload" href="{prefix}/{name}">' for name in modules)


def _dashboard_index(files: dict[str, StaticFile], versioned: str | None) -> StaticFile:
    """``index.html`` naming the files under ``/v/<versioned>/`` (plain addresses when None)."""
    prefix = "" if versioned is None else f"/v/{versioned}"
    html = files["index.html"].body.decode("utf-8").replace(HTML_PLACEHOLDER, f'href="{plotly_url()}"')
    if prefix:
        for name in ("/js/app.js", "/style.css", "/favicon.svg"):
            html = html.replace(f'"{name}"', f'"{prefix}{name}"')
    html = html.replace(MODULES_PLACEHOLDER, _module_preloads(files, prefix))
    body = html.encode()
    return StaticFile(body, "text/html; charset=utf-8", '"' + hashlib.sha256(body).hexdigest()[:32] + '"')


def _serve_vendor_file(app: FastAPI, url: str, file: VendorFile) -> None:
    @app.api_route(url, methods=["GET", "HEAD"], include_in_schema=False)
    def vendor_file(request: Request) -> Response:
        return file.response(request)


def install_static(app: FastAPI) -> None:
    """Vendored libraries, then the dashboard at ``/`` (after every other route)."""
    versioned = plotly_url()
    _serve_vendor_file(app, versioned, VendorFile.read(plotly_js(), "text/javascript"))

    @app.api_route(PLOTLY_ALIAS, methods=["GET", "HEAD"], include_in_schema=False)
    def plotly_alias() -> Response:
        """The unversioned address of earlier releases: a redirect, revalidated, to the versioned one."""
        return RedirectResponse(versioned, status_code=307, headers={"cache-control": REVALIDATE})

    for name, media_type in DOCS_ASSETS.items():
        _serve_vendor_file(app, docs_asset_url(name), VendorFile.read(docs_assets_dir() / name, media_type))

    directory = frontend_dir()
    if directory is None:
        return
    # The files as this process found them at start, served from memory: a reinstall under a running
    # service (the README's second install) leaves the dashboard as it was until the next start.
    files = snapshot(directory)
    served = dashboard_digest(files)
    index = _dashboard_index(files, served)

    @app.api_route("/", methods=["GET", "HEAD"], include_in_schema=False)
    @app.api_route("/index.html", methods=["GET", "HEAD"], include_in_schema=False)
    def dashboard_index(request: Request) -> Response:
        headers = {"cache-control": REVALIDATE, "etag": index.etag}
        if index.etag in request.headers.get("if-none-match", ""):
            return Response(status_code=304, headers=headers)
        return Response(b"" if request.method == "HEAD" else index.body, media_type=index.media_type,
                        headers=headers | {"content-length": str(len(index.body))})

    app.mount("/v", SnapshotFiles(files, versioned=served), name="dashboard-versioned")
    app.mount("/", SnapshotFiles(files), name="dashboard")
