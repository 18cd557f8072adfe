"""The job list under many concurrent clients, against a real ``mgrao serve``: requests for the same
page at the same time share one reading of the database (backend.services.cache.SharedBuilds), and yet every
answer holds every change committed, by any process, before its request was sent."""

from __future__ import annotations

import http.client
import json
import threading
import time
from urllib.parse import urlsplit

import psycopg
import pytest

from backend.store import crud
from backend.store.db import Database
from backend.store.models import SUCCEEDED, Job
from tests.backend.backend_helpers import JSON

CLIENTS = 8
VERSIONS = 150


class Poller(threading.Thread):
    """GET one listing back to back on a keep-alive connection; records (time sent, answer)."""

    def __init__(self, base: str, path: str) -> None:
        super().__init__(daemon=True)
        parts = urlsplit(base)
        self.host, self.port, self.path = parts.hostname, parts.port, path
        self.stop = threading.Event()
        self.seen: list[tuple[float, dict]] = []
        self.error: BaseException | None = None

    def run(self) -> None:
        connection = http.client.HTTPConnection(self.host, self.port, timeout=60)
        try:
            while not self.stop.is_set():
                sent = time.monotonic()
                connection.request("GET", self.path)
                response = connection.getresponse()
                body = response.read()
                assert response.status == 200, body[:300]
                self.seen.append((sent, json.loads(body)))
        except BaseException as error:  # noqa: BLE001 - reported by the test
            self.error = error
        finally:
            connection.close()


def stop_all(pollers: list[Poller]) -> None:
    for poller in pollers:
        poller.stop.set()
    for poller in pollers:
        poller.join(60)
        assert not poller.is_alive(), "a client was still waiting for an answer 60 s after the test stopped it"
        assert poller.error is None, f"a client failed: {poller.error!r}"


def test_every_answer_holds_what_other_processes_committed_before_its_request(service, db_url):
    """Eight clients poll the list while this process (not the server) renames a job 150 times and
    a real worker process runs another: every GET sent after a commit shows it."""
    service.start_server(workers=0)
    small = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 10}
    renamed = service.post("/api/jobs", json=small | {"name": "v0"}, headers=JSON).json()["id"]
    run = service.post("/api/jobs", json=small | {"name": "run by a worker"}, headers=JSON).json()["id"]
    db = Database(db_url)
    pollers = [Poller(service.base, "/api/jobs") for _ in range(CLIENTS)]
    for poller in pollers:
        poller.start()
    commits: list[float] = []  # time the k-th rename's commit returned, k = 1 ..
    try:
        service.wait_for(lambda: all(p.seen or p.error for p in pollers), 60, "every client's first answer")
        for version in range(1, VERSIONS + 1):
            with db.write() as session:
                crud.update_job(session, job_id=renamed, name=f"v{version}")
            commits.append(time.monotonic())
            time.sleep(0.01)
        service.start_worker()  # another process: claims, runs and finishes the job

        def succeeded() -> bool:
            with db.session() as session:
                return session.get(Job, run).status == SUCCEEDED

        service.wait_for(succeeded, 120, "the worker process to finish the job")
        finished = time.monotonic()
        service.wait_for(lambda: all(any(sent > finished for sent, _ in p.seen) or p.error for p in pollers),
                         60, "an answer to a request sent after the job finished, for every client")
    finally:
        stop_all(pollers)
        db.dispose()

    answers = [answer for poller in pollers for answer in poller.seen]
    assert len(answers) >= 3 * CLIENTS, len(answers)
    versions = set()
    for sent, page in answers:
        jobs = {job["id"]: job for job in page["data"]}
        shown = int(jobs[renamed]["name"][1:])
        versions.add(shown)
        committed = sum(1 for moment in commits if moment < sent)
        assert shown >= committed, f"a request sent after rename v{committed} was committed was answered v{shown}"
        if sent > finished:
            assert jobs[run]["status"] == SUCCEEDED, jobs[run]
            assert set(jobs[run]["summaries"]) == {"uniform", "mgrao-max"}, jobs[run]["summaries"]
    assert {0, VERSIONS} <= versions, versions  # the clients saw the first name and the last


def lock_waiters(connection: psycopg.Connection) -> int:
    """Sessions of the server waiting for a lock on this database."""
    return connection.execute(
        "SELECT count(*) FROM pg_stat_activity WHERE datname = current_database() AND wait_event_type = 'Lock'"
    ).fetchone()[0]


def test_concurrent_requests_for_one_page_wait_on_one_reading(service, db_url):
    """With the jobs table locked, 20 concurrent GETs of one page put one query of the server in the
    lock's queue, not 20; once the lock goes, all 20 are answered, alike."""
    if not db_url.startswith("postgresql"):
        pytest.skip("a reader waits for a table lock only on PostgreSQL (SQLite's WAL readers never wait)")
    service.start_server(workers=0)
    for i in range(3):
        service.post("/api/jobs", json={"system": "single", "seeds": 1, "episodes": 5, "name": f"job {i}"},
                     headers=JSON)
    conninfo = db_url.replace("postgresql+psycopg://", "postgresql://")
    answers: list[tuple[int, bytes]] = []
    sent = threading.Semaphore(0)

    def one_get() -> None:
        connection = http.client.HTTPConnection("127.0.0.1", service.port, timeout=120)
        connection.request("GET", "/api/jobs?limit=2")
        sent.release()
        response = connection.getresponse()
        answers.append((response.status, response.read()))
        connection.close()

    with psycopg.connect(conninfo) as holder, psycopg.connect(conninfo, autocommit=True) as watcher:
        holder.execute("LOCK TABLE jobs IN ACCESS EXCLUSIVE MODE")
        clients = [threading.Thread(target=one_get, daemon=True) for _ in range(20)]
        for client in clients:
            client.start()
        for _ in clients:
            assert sent.acquire(timeout=60), "a client could not send its request within 60 s"
        deadline = time.monotonic() + 60
        while lock_waiters(watcher) == 0:
            assert time.monotonic() < deadline, "no query of the server waited for the locked table within 60 s"
            time.sleep(0.05)
        most = 0
        settle = time.monotonic() + 3  # the 20 requests are sent: give the server time to start what it would
        while time.monotonic() < settle:
            most = max(most, lock_waiters(watcher))
            time.sleep(0.05)
        holder.rollback()
    for client in clients:
        client.join(120)
        assert not client.is_alive(), "a client had no answer 120 s after the lock was released"
    assert most == 1, f"{most} queries of the server waited for the lock at once"
    assert [status for status, _ in answers] == [200] * 20
    assert len({body for _, body in answers}) == 1
