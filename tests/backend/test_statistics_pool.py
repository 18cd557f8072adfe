"""The comparison statistics run in a bounded pool of their own, so that a burst of them starves nothing else.

Against a real ``mgrao serve`` (no workers; the jobs were run by a worker process stopped before), on SQLite and
PostgreSQL (docs/service.md, "Statistics under load"). What is checked is behaviour: which requests are answered,
with which status and headers, before a deadline far beyond what each needs; timings are the benchmark's
(benchmarks/bench_stats_burst.py).
"""

from __future__ import annotations

import socket
import threading
from collections import Counter

import httpx
import pytest
from backend_helpers import Service

from mgrao_cli.supervisor import stop_processes
from tests.support.waiting import join_all

pytestmark = pytest.mark.slow

JOBS = [{"system": system, "algorithms": ["uniform", "mgrao-1:1", "mgrao-max", "oracle"], "seeds": 60,
         "episodes": 20, "name": f"burst {system}"} for system in ("single", "multi")]
SMALL_JOB = {"system": "single", "algorithms": ["uniform"], "seeds": 1, "episodes": 5, "name": "probe"}
RETRY_AFTER = 7
LIGHT_DEADLINE_S = 10.0
"""Longest a light request may take during the burst: far beyond what it needs (the benchmark's p99 is under
0.3 s); before the pool, such requests waited behind the burst for every thread of the process (61-66 s)."""
HEAVY_DEADLINE_S = 120.0


def _computing(seed: int, what: str = "computing") -> str:
    """The log line's words when the statistics asked with ``seed`` (no aggregate chosen) start computing."""
    return f"seed={seed}, aggregate=[]): {what}"


def _start(service: Service, **settings: object) -> list[int]:
    """The service with the stored jobs of :data:`JOBS`, run by a worker process that is then stopped."""
    service.env.update({f"MGRAO_{name.upper()}": str(value) for name, value in settings.items()})
    worker = service.start_worker()  # first: it loads while the server starts (the database is migrated already)
    service.start_server(workers=0)
    ids = [service.post("/api/jobs", json=job).json()["id"] for job in JOBS]
    for job_id in ids:
        service.wait_for(lambda job_id=job_id: service.get(f"/api/jobs/{job_id}").json()["status"] == "succeeded",
                         timeout=300, what=f"job {job_id} to succeed")
    stop_processes([worker], 30)
    service.workers.remove(worker)
    return ids


def _statistics(ids: list[int], seed: int, reps: int = 50_000) -> str:
    return f"/api/compare/statistics?jobs={','.join(map(str, ids))}&reps={reps}&seed={seed}"


def _curves(ids: list[int], seed: int, reps: int = 20_000) -> str:
    return f"/api/compare/sample-efficiency?jobs={','.join(map(str, ids))}&points=20&reps={reps}&seed={seed}"


def test_a_burst_of_statistics_leaves_the_light_routes_answering_and_is_answered_200_or_503(service: Service) -> None:
    ids = _start(service, stats_workers=1, stats_queue=2, stats_wait_s=60, stats_retry_after_s=RETRY_AFTER)
    heavy: list[tuple[str, int, str | None]] = []
    light: list[tuple[str, int | str]] = []
    burst_over = threading.Event()

    def ask(path: str) -> None:
        try:
            with httpx.Client(timeout=HEAVY_DEADLINE_S) as client:
                response = client.get(service.base + path)
            heavy.append((path, response.status_code, response.headers.get("retry-after")))
        except httpx.HTTPError as error:
            heavy.append((path, -1, f"{type(error).__name__}: {error}"))

    def probe() -> None:
        with httpx.Client(base_url=service.base, timeout=LIGHT_DEADLINE_S) as client:
            while not burst_over.is_set():
                for method, path in (("GET", "/api/health"), ("GET", "/api/jobs"), ("GET", f"/api/jobs/{ids[0]}"),
                                     ("POST", "/api/jobs")):
                    try:
                        response = client.request(method, path, json=SMALL_JOB if method == "POST" else None)
                        light.append((f"{method} {path}", response.status_code))
                    except httpx.HTTPError as error:  # a timeout here: the light route waited past its deadline
                        light.append((f"{method} {path}", f"{type(error).__name__}: {error}"))

    prober = threading.Thread(target=probe, daemon=True)
    prober.start()
    paths = [_statistics(ids, seed) for seed in range(30)] + [_curves(ids, seed) for seed in range(30)]
    threads = [threading.Thread(target=ask, args=(path,), daemon=True) for path in paths]
    for thread in threads:
        thread.start()
    join_all(threads, HEAVY_DEADLINE_S + 30, "the burst's 60 statistics requests")
    burst_over.set()
    join_all([prober], 4 * LIGHT_DEADLINE_S, "the light routes' prober")

    assert len(heavy) == len(paths)
    statuses = Counter(status for _, status, _ in heavy)
    assert set(statuses) <= {200, 503}, [h for h in heavy if h[1] not in (200, 503)]
    assert statuses[200] >= 1 and statuses[503] >= 1, statuses  # the pool computed some, refused the rest
    assert all(retry == str(RETRY_AFTER) for _, status, retry in heavy if status == 503)
    kinds = Counter(route for route, _ in light)
    assert len(kinds) == 4 and min(kinds.values()) >= 1, kinds
    wrong = [(route, status) for route, status in light if status != (202 if route.startswith("POST") else 200)]
    assert not wrong, wrong[:10]
    # and what the pool answered 200 is the answer computed alone
    answered = next(path for path, status, _ in heavy if status == 200)
    assert httpx.get(service.base + answered, timeout=HEAVY_DEADLINE_S).status_code == 200


def _send_and_close(service: Service, path: str) -> None:
    """Send a request and close the connection before its answer: a client that went away."""
    with socket.create_connection(("127.0.0.1", service.port), timeout=10) as connection:
        connection.sendall(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{service.port}\r\n\r\n".encode())


def test_a_request_whose_client_left_before_its_turn_is_not_computed(service: Service) -> None:
    ids = _start(service, stats_workers=1, stats_queue=1, stats_wait_s=120, stats_retry_after_s=RETRY_AFTER)
    first, gone, later = (_statistics(ids, seed) for seed in (101, 102, 103))
    answers: dict[str, int] = {}

    def ask(path: str) -> None:
        answers[path] = httpx.get(service.base + path, timeout=HEAVY_DEADLINE_S).status_code

    running = threading.Thread(target=ask, args=(first,), daemon=True)
    running.start()
    service.wait_for(lambda: _computing(101) in service.logs(), timeout=60, what="the first to be computed")
    _send_and_close(service, gone)  # queued behind the first, then its client is gone
    service.wait_for(lambda: _computing(102, "not computed") in service.logs(), timeout=60,
                     what="the request whose client left to leave the queue")
    queued = threading.Thread(target=ask, args=(later,), daemon=True)  # takes the place it left
    queued.start()
    join_all([running, queued], HEAVY_DEADLINE_S + 30, "the first request and the one queued after it")
    assert answers == {first: 200, later: 200}
    logs = service.logs()
    assert _computing(103) in logs
    assert _computing(102) not in logs  # never run: it would have run before the later one


def test_the_same_statistics_asked_again_share_one_computation_and_a_full_pool_refuses_others(
        service: Service) -> None:
    ids = _start(service, stats_workers=1, stats_queue=0, stats_wait_s=120, stats_retry_after_s=RETRY_AFTER)
    path = _statistics(ids, 201)
    answers: list[httpx.Response] = []

    def ask() -> None:
        answers.append(httpx.get(service.base + path, timeout=HEAVY_DEADLINE_S))

    threads = [threading.Thread(target=ask, daemon=True)]
    threads[0].start()
    service.wait_for(lambda: _computing(201) in service.logs(), timeout=60, what="the answer to be computed")
    threads += [threading.Thread(target=ask, daemon=True) for _ in range(3)]  # join the computation running
    for thread in threads[1:]:
        thread.start()
    refused = httpx.get(service.base + _curves(ids, 202), timeout=HEAVY_DEADLINE_S)  # a thread, no queue: full
    join_all(threads, HEAVY_DEADLINE_S + 30, "four requests for one answer")
    assert refused.status_code == 503 and refused.headers["retry-after"] == str(RETRY_AFTER)
    assert "MGRAO_STATS_WORKERS" in refused.json()["detail"]
    assert [a.status_code for a in answers] == [200] * 4
    assert len({a.content for a in answers}) == 1
    assert httpx.get(service.base + path, timeout=HEAVY_DEADLINE_S).content == answers[0].content  # kept
    assert service.logs().count(_computing(201)) == 1
