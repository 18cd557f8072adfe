"""The API's documentation page, ``/docs`` (Swagger UI), from local assets.

FastAPI's own page loads Swagger UI from a CDN (blank offline) and starts it with an inline script
(refused by the Content-Security-Policy). This page loads the copy that the ``fastapi-offline``
package ships (served by :mod:`backend.api.static`) and starts Swagger UI from a same-origin script, so
it works offline and under ``script-src 'self'``.

There is no ReDoc page: ReDoc always shows a logo loaded from its vendor's site, and no page of the
service requests anything outside it. ``/redoc`` redirects to ``/docs``.
"""

from __future__ import annotations

from html import escape

from fastapi import FastAPI, Request, Response
from fastapi.responses import HTMLResponse, RedirectResponse

from backend.api.static import REVALIDATE, docs_asset_url

SWAGGER_INIT_URL = "/docs/swagger-init.js"
SWAGGER_INIT = """// Starts Swagger UI in #swagger-ui on the OpenAPI document named by data-url (backend/api/apidocs.py)
(function () {
  const root = document.getElementById('swagger-ui');
  window.ui = SwaggerUIBundle({
    url: root.dataset.url,
    dom_id: '#swagger-ui',
    layout: 'BaseLayout',
    deepLinking: true,
    showExtensions: true,
    showCommonExtensions: true,
    validatorUrl: null,
    presets: [SwaggerUIBundle.presets.apis, SwaggerUIBundle.SwaggerUIStandalonePreset],
  });
}());
"""

PAGE = """<!doctype html>
<html lang="en">
<head>
  <meta charset="utf-8">
  <meta name="viewport" content="width=device-width, initial-scale=1">
  <title>{title}</title>
  <link rel="icon" href="{root}/favicon.svg" type="image/svg+xml">
{head}</head>
<body>
{body}
</body>
</html>
"""


def _page(title: str, root: str, head: str, body: str) -> HTMLResponse:
    html = PAGE.format(title=escape(title), root=escape(root), head=head, body=body)
    return HTMLResponse(html, headers={"cache-control": REVALIDATE})


def install_api_docs(app: FastAPI) -> None:
    """``/docs``, its start-up script and ``/redoc`` (create the app with docs_url=redoc_url=None)."""
    openapi_url = app.openapi_url or "/openapi.json"

    @app.api_route("/docs", methods=["GET", "HEAD"], include_in_schema=False)
    def swagger_ui(request: Request) -> HTMLResponse:
        root = escape(request.scope.get("root_path", ""))
        head = f'  <link rel="stylesheet" href="{root}{docs_asset_url("swagger-ui.css")}">\n'
        body = (f'<div id="swagger-ui" data-url="{root}{escape(openapi_url)}"></div>\n'
                f'<script src="{root}{docs_asset_url("swagger-ui-bundle.js")}"></script>\n'
                f'<script src="{root}{SWAGGER_INIT_URL}"></script>')
        return _page(f"{app.title} - Swagger UI", root, head, body)

    @app.api_route(SWAGGER_INIT_URL, methods=["GET", "HEAD"], include_in_schema=False)
    def swagger_init() -> Response:
        return Response(SWAGGER_INIT, media_type="text/javascript", headers={"cache-control": REVALIDATE})

    @app.api_route("/redoc", methods=["GET", "HEAD"], include_in_schema=False)
    def redoc(request: Request) -> RedirectResponse:
        """FastAPI's second docs page, dropped (see the module's docstring): to ``/docs``."""
        return RedirectResponse(request.scope.get("root_path", "") + "/docs", status_code=307,
                                headers={"cache-control": REVALIDATE})
