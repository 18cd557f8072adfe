"""Every body over MGRAO_MAX_BODY_BYTES answers 413 naming the limit, chunked or with Content-Length."""

from __future__ import annotations

import json
import socket
from collections.abc import Iterator
from urllib.parse import urlparse

import httpx
import pytest
from fastapi.testclient import TestClient

LIMIT = 65536
TEN_MB = 10 * 1024 * 1024
JSON = {"Content-Type": "application/json"}
SMALL_JOB = {"system": "single", "seeds": 1, "episodes": 5}


def chunks(total: int, size: int = 64 * 1024) -> Iterator[bytes]:
    """A JSON-looking body of ``total`` bytes, in pieces (httpx sends a generator chunked)."""
    yield b'{"notes": "'
    sent = 11
    while sent < total:
        piece = b"x" * min(size, total - sent)
        sent += len(piece)
        yield piece


def assert_413(response: httpx.Response) -> None:
    assert response.status_code == 413, response.text
    detail = response.json()["detail"]
    assert isinstance(detail, str) and str(LIMIT) in detail and "MGRAO_MAX_BODY_BYTES" in detail


@pytest.mark.parametrize("path", ["/api/jobs", "/api/jobs/1", "/api/jobs/1/cancel"])
def test_chunked_10mb_body_is_413_in_process(client: TestClient, path: str) -> None:
    method = "PATCH" if path == "/api/jobs/1" else "POST"
    response = client.request(method, path, content=chunks(TEN_MB), headers=JSON)
    assert "content-length" not in response.request.headers  # really chunked
    assert_413(response)


def test_declared_length_over_the_limit_is_413_in_process(client: TestClient) -> None:
    assert_413(client.post("/api/jobs", content=b"{" * (LIMIT + 1), headers=JSON))


def test_chunked_body_under_the_limit_still_reaches_the_route(client: TestClient) -> None:
    body = json.dumps({**SMALL_JOB, "notes": "y" * 9_000}).encode() + b" " * 56_000  # JSON may end in spaces
    assert LIMIT - 1000 < len(body) <= LIMIT
    response = client.post("/api/jobs", content=iter([body[:1000], body[1000:30_000], body[30_000:]]), headers=JSON)
    assert response.status_code == 202, response.text
    assert response.json()["notes"] == "y" * 9_000


def test_chunked_10mb_body_is_413_from_a_real_server(live_server: str) -> None:
    with httpx.Client(base_url=live_server, timeout=30) as http:
        response = http.post("/api/jobs", content=chunks(TEN_MB), headers=JSON)
        assert "content-length" not in response.request.headers
        assert_413(response)
        # the server is still fine afterwards
        assert http.post("/api/jobs", json=SMALL_JOB).status_code == 202


def test_declared_10mb_body_is_413_from_a_real_server(live_server: str) -> None:
    response = httpx.post(f"{live_server}/api/jobs", content=b"x" * TEN_MB, headers=JSON, timeout=30)
    assert response.request.headers["content-length"] == str(TEN_MB)
    assert_413(response)


def test_chunked_body_over_a_raw_socket_is_413(live_server: str) -> None:
    """What a hand-written client sees: headers, then chunks until the server answers."""
    url = urlparse(live_server)
    head = (f"POST /api/jobs HTTP/1.1\r\nHost: {url.netloc}\r\nContent-Type: application/json\r\n"
            "Transfer-Encoding: chunked\r\n\r\n").encode()
    with socket.create_connection((url.hostname, url.port), timeout=30) as sock:
        sock.sendall(head)
        try:
            for piece in chunks(TEN_MB):
                sock.sendall(b"%x\r\n%s\r\n" % (len(piece), piece))
            sock.sendall(b"0\r\n\r\n")
        except OSError:
            pass  # the server answered and closed before the whole body was sent
        answer = b""
        try:
            while data := sock.recv(65536):
                answer += data
        except ConnectionResetError:
            pass
    status_line, _, rest = answer.partition(b"\r\n")
    assert status_line.startswith(b"HTTP/1.1 413"), answer[:300]
    body = rest.split(b"\r\n\r\n", 1)[1]
    assert str(LIMIT) in json.loads(body)["detail"]
