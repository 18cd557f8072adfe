"""Every body over MGRAO_MAX_BODY_BYTES answers 413 naming the limit, chunked or with Content-Length."""

from __future__ import annotations

import asyncio
import json
import socket
from collections.abc import Iterator
from urllib.parse import urlparse

import httpx
import pytest
from fastapi.testclient import TestClient

from backend.api.limits import DRAIN_BYTES, BodyLimit

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
    assert_names_the_limit(response.content)


def assert_names_the_limit(body: bytes) -> None:
    detail = json.loads(body)["detail"]
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
        # the whole body goes through: the server reads and drops the rest of a refused body
        for piece in chunks(TEN_MB):
            sock.sendall(b"%x\r\n%s\r\n" % (len(piece), piece))
        sock.sendall(b"0\r\n\r\n")
        assert_413_answer(read_all(sock))


def read_all(sock: socket.socket) -> bytes:
    answer = b""
    while data := sock.recv(65536):
        answer += data
    return answer


def assert_413_answer(answer: bytes) -> None:
    status_line, _, rest = answer.partition(b"\r\n")
    assert status_line.startswith(b"HTTP/1.1 413"), answer[:300]
    assert_names_the_limit(rest.split(b"\r\n\r\n", 1)[1])


def test_a_client_that_sends_its_whole_declared_body_before_reading_gets_the_413(live_server: str) -> None:
    """Closing a socket with unread bytes sends a TCP reset, which destroys the answer on its way: a
    client in the middle of sending lost the 413 (15 of 200 under load). The server reads what is left."""
    url = urlparse(live_server)
    head = (f"POST /api/jobs HTTP/1.1\r\nHost: {url.netloc}\r\nContent-Type: application/json\r\n"
            f"Content-Length: {TEN_MB}\r\n\r\n").encode()
    with socket.create_connection((url.hostname, url.port), timeout=30) as sock:
        sock.sendall(head)
        sock.sendall(b"x" * TEN_MB)  # raised ConnectionResetError/BrokenPipeError when the server closed early
        assert_413_answer(read_all(sock))


@pytest.mark.parametrize("expect", ["100-continue", "100-Continue, foo"])
def test_expect_100_continue_is_refused_before_the_body(live_server: str, expect: str) -> None:
    """A client asking ``Expect: 100-continue`` with a declared length over the limit waits for the
    go-ahead: it gets the 413 instead, and never sends its body."""
    url = urlparse(live_server)
    head = (f"POST /api/jobs HTTP/1.1\r\nHost: {url.netloc}\r\nContent-Type: application/json\r\n"
            f"Content-Length: {TEN_MB}\r\nExpect: {expect}\r\n\r\n").encode()
    with socket.create_connection((url.hostname, url.port), timeout=30) as sock:
        sock.sendall(head)
        assert_413_answer(read_all(sock))  # no "100 Continue" before it


def test_a_refused_body_that_stalls_is_answered_within_the_drain_time(live_server: str) -> None:
    """Reading a refused body is bounded in time (backend.api.limits.DRAIN_S): a client that declares a large
    body and stops sending gets its 413 all the same."""
    url = urlparse(live_server)
    head = (f"POST /api/jobs HTTP/1.1\r\nHost: {url.netloc}\r\nContent-Type: application/json\r\n"
            f"Content-Length: {1024 ** 3}\r\n\r\n").encode()
    with socket.create_connection((url.hostname, url.port), timeout=30) as sock:
        sock.sendall(head + b"x" * 1024)
        assert_413_answer(read_all(sock))


def run_limit(headers: list[tuple[bytes, bytes]], messages: list[dict]) -> tuple[int, list[dict]]:
    """Drive BodyLimit over a request whose body arrives as ``messages`` (then 1 MiB pieces without end);
    how many times it read, and what it sent."""
    asked = 0
    sent: list[dict] = []

    async def receive() -> dict:
        nonlocal asked
        asked += 1
        if asked <= len(messages):
            return messages[asked - 1]
        return {"type": "http.request", "body": b"x" * 2**20, "more_body": True}

    async def send(message: dict) -> None:
        sent.append(message)

    async def never(scope, receive, send) -> None:
        raise AssertionError("an oversized body reached the app")

    scope = {"type": "http", "http_version": "1.1", "method": "POST", "path": "/api/jobs",
             "headers": [(b"content-type", b"application/json"), *headers]}
    asyncio.run(BodyLimit(never, max_bytes=LIMIT)(scope, receive, send))
    return asked, sent


def test_reading_a_refused_body_stops_at_the_drain_bytes() -> None:
    """A client that sends without end: the middleware reads DRAIN_BYTES past the limit, then answers."""
    asked, sent = run_limit([], [])
    assert sent[0]["status"] == 413
    assert asked == DRAIN_BYTES // 2**20 + 1  # the piece that passed the limit, then DRAIN_BYTES dropped


def test_a_declared_body_beyond_the_drain_bytes_is_refused_unread() -> None:
    asked, sent = run_limit([(b"content-length", str(LIMIT + DRAIN_BYTES + 1).encode())], [])
    assert asked == 0 and sent[0]["status"] == 413


def test_a_client_that_leaves_while_its_body_is_drained_gets_no_answer() -> None:
    piece = {"type": "http.request", "body": b"x" * 2**20, "more_body": True}
    asked, sent = run_limit([(b"content-length", str(TEN_MB).encode())], [piece, piece, {"type": "http.disconnect"}])
    assert asked == 3 and sent == []
