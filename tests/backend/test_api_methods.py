"""An /api path answers 405 with its own Allow for a method it does not take, and an unknown /api path 404 JSON.

Before, both fell through to the dashboard's files mounted at "/": ``PUT /api/jobs/1/cancel``
answered ``405 Allow: GET, HEAD`` and ``GET /api/nope`` an HTML 404. Against a real ``mgrao serve``.
"""

from __future__ import annotations

import re

import httpx
from backend_helpers import JSON

METHODS = ("GET", "POST", "PUT", "PATCH", "DELETE", "OPTIONS")


def test_each_api_path_answers_405_with_the_methods_it_documents(live_server: str) -> None:
    document = httpx.get(f"{live_server}/openapi.json", timeout=30).json()
    assert document["paths"], "the OpenAPI document lists no paths"
    for template, operations in document["paths"].items():
        path = re.sub(r"\{[^}]+\}", "1", template)
        documented = {method.upper() for method in operations}
        allow = ", ".join(sorted(documented))
        for method in METHODS:
            if method in documented:
                continue
            for headers in (JSON, {}):  # a write without Content-Type too: 405 before the content-type rule
                response = httpx.request(method, live_server + path, headers=headers, timeout=30)
                where = f"{method} {path} {headers}"
                assert response.status_code == 405, f"{where}: {response.status_code} {response.text}"
                assert response.headers["allow"] == allow, f"{where}: Allow {response.headers['allow']}"
                assert response.headers["content-type"] == "application/json", where
                assert method in response.json()["detail"] and allow in response.json()["detail"], where


def test_the_issue_example_put_on_cancel(live_server: str) -> None:
    response = httpx.put(f"{live_server}/api/jobs/1/cancel", headers=JSON, timeout=30)
    assert (response.status_code, response.headers["allow"]) == (405, "POST"), response.text


def test_an_unknown_api_path_answers_404_json(live_server: str) -> None:
    for method, path in [("GET", "/api/nope"), ("GET", "/api"), ("GET", "/api/jobs/"), ("GET", "/api/jobs/1.0"),
                         ("DELETE", "/api/jobs/1.0"), ("POST", "/api/jobs/1/nope"), ("PUT", "/api/nope")]:
        response = httpx.request(method, live_server + path, headers=JSON, timeout=30)
        assert response.status_code == 404, f"{method} {path}: {response.status_code} {response.text}"
        assert response.headers["content-type"] == "application/json", f"{method} {path}"
        assert "allow" not in response.headers
        assert response.json() == {"detail": "no such API path (see /docs)"}
    # the dashboard's own paths are unchanged
    assert httpx.get(f"{live_server}/", timeout=30).status_code == 200
    assert httpx.get(f"{live_server}/nope.js", timeout=30).status_code == 404
