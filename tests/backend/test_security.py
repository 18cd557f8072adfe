"""Cross-site requests: allowed Host names, same-origin writes, and security headers on every answer."""

from __future__ import annotations

from collections.abc import Iterator
from urllib.parse import urlparse

import httpx
import pytest
from backend_helpers import BASE_URL, JSON
from fastapi.testclient import TestClient

from backend.api.app import create_app
from backend.api.security import CONTENT_SECURITY_POLICY, split_host
from backend.settings import Settings

SMALL = {"system": "single", "seeds": 1, "episodes": 5}
EVIL = "http://evil.example"


def queued_job(client: TestClient) -> int:
    response = client.post("/api/jobs", json=SMALL)
    assert response.status_code == 202, response.text
    return response.json()["id"]


def status_of(client: TestClient, job_id: int) -> str:
    return client.get(f"/api/jobs/{job_id}").json()["status"]


@pytest.fixture
def make_client(settings: Settings) -> Iterator:
    """TestClients of apps with some settings changed, addressed at ``base_url``."""
    made: list[TestClient] = []

    def make(base_url: str = BASE_URL, **changes: object) -> TestClient:
        test_client = TestClient(create_app(settings.model_copy(update=changes)), base_url=base_url)
        test_client.__enter__()
        made.append(test_client)
        return test_client

    yield make
    for test_client in made:
        test_client.__exit__(None, None, None)


# ---- CSRF: writes need a JSON content type or the server's own Origin ---------------------------


def test_cross_origin_cancel_without_body_is_refused(client: TestClient) -> None:
    job_id = queued_job(client)
    response = client.post(f"/api/jobs/{job_id}/cancel", headers={"Origin": EVIL})
    assert response.status_code == 403
    assert "cross-origin" in response.json()["detail"] and EVIL in response.json()["detail"]
    assert status_of(client, job_id) == "queued"


@pytest.mark.parametrize("content_type", [None, "application/json", "text/plain", "application/x-www-form-urlencoded"])
@pytest.mark.parametrize(
    "origin", [EVIL, "null", "http://127.0.0.1:8000", "https://127.0.0.1", "http://localhost", "http://127.0.0.1/x"],
)
def test_foreign_origin_is_403_whatever_the_content_type(client: TestClient, origin: str,
                                                          content_type: str | None) -> None:
    job_id = queued_job(client)
    headers = {"Origin": origin} | ({"Content-Type": content_type} if content_type else {})
    for method, path in [("POST", f"/api/jobs/{job_id}/cancel"), ("PATCH", f"/api/jobs/{job_id}"),
                         ("DELETE", f"/api/jobs/{job_id}"), ("POST", "/api/jobs")]:
        content = b'{"name": "x"}' if method == "PATCH" else None
        response = client.request(method, path, headers=headers, content=content)
        assert response.status_code == 403, (method, path, response.text)
    assert status_of(client, job_id) == "queued"
    assert client.get(f"/api/jobs/{job_id}").json()["name"] == ""


@pytest.mark.parametrize(
    "content_type", [None, "text/plain", "application/x-www-form-urlencoded", "multipart/form-data; boundary=x",
                     "application/jsonp", "text/json"],
)
def test_write_without_origin_needs_json_content_type(client: TestClient, content_type: str | None) -> None:
    job_id = queued_job(client)
    headers = {"Content-Type": content_type} if content_type else {}
    for method, path in [("POST", f"/api/jobs/{job_id}/cancel"), ("DELETE", f"/api/jobs/{job_id}")]:
        response = client.request(method, path, headers=headers)
        assert response.status_code == 415, response.text
        detail = response.json()["detail"]
        assert "Content-Type: application/json" in detail and repr(content_type or "none") in detail
    response = client.post("/api/jobs", content=b'{"system": "single"}', headers=headers)
    assert response.status_code == 415
    assert status_of(client, job_id) == "queued"


@pytest.mark.parametrize("content_type", ["application/json", "application/json; charset=utf-8", "Application/JSON"])
def test_write_with_json_content_type_and_no_body_passes(client: TestClient, content_type: str) -> None:
    job_id = queued_job(client)
    response = client.post(f"/api/jobs/{job_id}/cancel", headers={"Content-Type": content_type})
    assert response.status_code == 200 and response.json()["status"] == "cancelled"
    assert client.delete(f"/api/jobs/{job_id}", headers={"Content-Type": content_type}).status_code == 204


@pytest.mark.parametrize("content_type", [None, "text/plain"])
def test_same_origin_write_passes_whatever_the_content_type(client: TestClient, content_type: str | None) -> None:
    job_id = queued_job(client)
    headers = {"Origin": BASE_URL} | ({"Content-Type": content_type} if content_type else {})
    response = client.post(f"/api/jobs/{job_id}/cancel", headers=headers)
    assert response.status_code == 200 and response.json()["status"] == "cancelled"


def test_reads_are_not_write_checked(client: TestClient) -> None:
    assert client.get("/api/jobs", headers={"Origin": EVIL}).status_code == 200
    assert client.get("/api/health").status_code == 200


def test_cross_origin_cancel_against_a_real_server(live_server: str) -> None:
    with httpx.Client(base_url=live_server, timeout=30) as http:
        job_id = http.post("/api/jobs", json=SMALL).json()["id"]
        refused = http.post(f"/api/jobs/{job_id}/cancel", headers={"Origin": "http://attacker.example"})
        assert refused.status_code == 403
        assert http.post(f"/api/jobs/{job_id}/cancel").status_code == 415
        assert http.get(f"/api/jobs/{job_id}").json()["status"] == "queued"
        own = http.post(f"/api/jobs/{job_id}/cancel", headers={"Origin": live_server, "Content-Type": "text/plain"})
        assert own.status_code == 200 and own.json()["status"] == "cancelled"


# ---- Host header: DNS rebinding ------------------------------------------------------------------


@pytest.mark.one_database
@pytest.mark.parametrize("path", ["/", "/api/health", "/api/jobs", "/docs", "/openapi.json"])
def test_unknown_host_is_400(make_client, path: str) -> None:
    response = make_client(EVIL).get(path)
    assert response.status_code == 400
    assert "evil.example" in response.json()["detail"] and "MGRAO_ALLOWED_HOSTS" in response.json()["detail"]


@pytest.mark.parametrize("base", ["http://127.0.0.1", "http://127.0.0.1:8123", "http://localhost:9",
                                  "http://LOCALHOST:8000"])
def test_default_hosts_on_any_port(make_client, base: str) -> None:
    assert make_client(base).get("/api/health").status_code == 200


def test_configured_hosts_replace_the_defaults(make_client) -> None:
    assert make_client("http://lab.example.org:8000", allowed_hosts=["lab.example.org"]).get("/").status_code == 200
    assert make_client("http://localhost:8000", allowed_hosts=["lab.example.org"]).get("/").status_code == 400
    # the address the server binds to stays allowed
    assert make_client("http://127.0.0.1:8000", allowed_hosts=["lab.example.org"]).get("/").status_code == 200
    bound = make_client("http://10.1.2.3:8000", host="10.1.2.3")
    assert bound.get("/api/health").status_code == 200
    assert make_client("http://[::1]:8000").get("/").status_code == 400
    assert make_client("http://[::1]:8000", allowed_hosts=["::1"]).get("/").status_code == 200


def test_star_allows_any_host(make_client) -> None:
    assert make_client(EVIL, allowed_hosts=["*"]).get("/api/health").status_code == 200


def test_allowed_hosts_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MGRAO_ALLOWED_HOSTS", " lab.example.org, 10.0.0.5 ,")
    assert Settings().allowed_hosts == ["lab.example.org", "10.0.0.5"]
    monkeypatch.setenv("MGRAO_ALLOWED_HOSTS", "*")
    assert Settings().allowed_hosts == ["*"]
    monkeypatch.delenv("MGRAO_ALLOWED_HOSTS")
    assert Settings().allowed_hosts == ["127.0.0.1", "localhost"]


def test_host_header_of_a_rebound_name_against_a_real_server(live_server: str) -> None:
    port = urlparse(live_server).port
    with httpx.Client(base_url=live_server, timeout=30) as http:
        assert http.get("/api/health", headers={"Host": f"rebound.attacker.example:{port}"}).status_code == 400
        assert http.get("/", headers={"Host": f"localhost:{port}"}).status_code == 200
        assert http.get("/api/health").status_code == 200


@pytest.mark.parametrize(
    ("value", "expected"),
    [("127.0.0.1:8000", ("127.0.0.1", 8000)), ("LocalHost", ("localhost", None)), ("[::1]:80", ("::1", 80)),
     ("example.org.:443", ("example.org", 443))],
)
def test_split_host(value: str, expected: tuple) -> None:
    assert split_host(value) == expected


@pytest.mark.parametrize("value", ["", "a:b", "[::1", "[::1]x", "a/b:80", "user@host", "host:99999", "h:\u0661"])
def test_split_host_refuses_malformed(value: str) -> None:
    with pytest.raises(ValueError):
        split_host(value)


# ---- security headers on every answer -------------------------------------------------------------


def assert_security_headers(response: httpx.Response) -> None:
    csp = response.headers.get("content-security-policy", "")
    directives = {d.split()[0]: d.split()[1:] for d in csp.split("; ")}
    assert directives["script-src"] == ["'self'"]
    assert directives["default-src"] == ["'self'"] and directives["connect-src"] == ["'self'"]
    assert directives["frame-ancestors"] == ["'none'"] and directives["base-uri"] == ["'none'"]
    assert directives["object-src"] == ["'none'"]
    assert directives["img-src"] == ["'self'", "data:", "blob:"]
    assert "'unsafe-eval'" not in csp
    assert response.headers["x-content-type-options"] == "nosniff"
    assert response.headers["referrer-policy"] == "no-referrer"
    assert response.headers["x-frame-options"] == "DENY"


@pytest.mark.one_database
def test_csp_constant_is_what_is_sent(client: TestClient) -> None:
    assert client.get("/").headers["content-security-policy"] == CONTENT_SECURITY_POLICY


@pytest.mark.parametrize(
    ("method", "path", "kwargs", "status"),
    [("GET", "/", {}, 200), ("GET", "/index.html", {}, 200), ("GET", "/js/app.js", {}, 200),
     ("GET", "/style.css", {}, 200), ("GET", "/no-such-file.js", {}, 404), ("GET", "/docs", {}, 200),
     ("GET", "/openapi.json", {}, 200), ("GET", "/api/health", {}, 200), ("GET", "/api/jobs/5", {}, 404),
     ("GET", "/api/jobs?limit=0", {}, 422), ("POST", "/api/jobs/5/cancel", {}, 415),
     ("POST", "/api/jobs/5/cancel", {"headers": {"Origin": EVIL}}, 403),
     ("POST", "/api/jobs", {"content": b"x" * 70_000, "headers": JSON}, 413), ("HEAD", "/", {}, 200)],
)
def test_security_headers_on_every_answer(client: TestClient, method: str, path: str, kwargs: dict,
                                          status: int) -> None:
    response = client.request(method, path, **kwargs)
    assert response.status_code == status, response.text
    assert_security_headers(response)


@pytest.mark.one_database
def test_security_headers_on_a_refused_host(make_client) -> None:
    response = make_client(EVIL).get("/")
    assert response.status_code == 400
    assert_security_headers(response)


def test_security_headers_from_a_real_server(live_server: str) -> None:
    for path in ("/", "/api/health", "/docs"):
        assert_security_headers(httpx.get(live_server + path, timeout=30))
