"""The ``workers`` table and ``/api/health``'s ``workers``: real `mgrao worker` processes on SQLite and
PostgreSQL, stopped cleanly (their row goes), SIGKILLed (their row stops counting after
``stale_after_s``) and, on PostgreSQL, frozen with SIGSTOP; rows unseen for an hour are forgotten."""

from __future__ import annotations

import os
import signal

from backend_helpers import Service
from fastapi.testclient import TestClient
from sqlalchemy import insert, select

from backend.execution import presence
from backend.execution.presence import Presence
from backend.store.db import Database
from backend.store.dialect import db_now
from backend.store.models import WorkerPresence
from tests.support.waiting import wait_until


def health_workers(service: Service) -> dict[str, int]:
    return service.get("/api/health").json()["workers"]


def rows(db_url: str) -> dict[str, str]:
    database = Database(db_url)
    try:
        with database.session() as session:
            return dict(session.execute(select(WorkerPresence.worker_id, WorkerPresence.state)).all())
    finally:
        database.dispose()


def test_worker_processes_report_ready_and_leave(service: Service) -> None:
    service.start_server(workers=0)
    assert health_workers(service) == {"warming": 0, "ready": 0}
    first, second = service.start_worker(), service.start_worker()
    service.wait_for(lambda: health_workers(service) == {"warming": 0, "ready": 2}, 90, "two ready workers")
    assert {int(worker_id.rsplit(":", 1)[1]) for worker_id in rows(service.db_url)} == {first.pid, second.pid}

    first.send_signal(signal.SIGTERM)  # a clean stop deletes its row
    first.wait(timeout=30)
    assert [int(w.rsplit(":", 1)[1]) for w in rows(service.db_url)] == [second.pid]
    # the second counts as long as it refreshed within stale_after_s (2 s): a loaded machine can delay that
    service.wait_for(lambda: health_workers(service) == {"warming": 0, "ready": 1}, 30, "one ready worker")

    if service.db_url.startswith("postgresql"):
        # frozen: no refresh, so it stops counting after stale_after_s (2 s). Not on SQLite: a process
        # frozen inside a write holds SQLite's one write lock, and every writer (the health probe too)
        # waits for it up to the busy timeout (docs/service.md, "Workers present").
        second.send_signal(signal.SIGSTOP)
        try:
            service.wait_for(lambda: health_workers(service) == {"warming": 0, "ready": 0}, 30, "the frozen to lapse")
        finally:
            second.send_signal(signal.SIGCONT)
        service.wait_for(lambda: health_workers(service)["ready"] == 1, 30, "the thawed worker to count again")

    os.kill(second.pid, signal.SIGKILL)  # killed: its row stays, counted no more
    second.wait(timeout=10)
    service.wait_for(lambda: health_workers(service) == {"warming": 0, "ready": 0}, 30, "the killed worker to lapse")
    assert list(rows(service.db_url)) == [f"{os.uname().nodename}:{second.pid}"]


def test_states_counts_and_forgetting(db: Database, client: TestClient) -> None:
    with db.write() as session:  # a process killed two hours ago, by the database clock
        old = db_now(session, minus_seconds=2 * presence.FORGET_AFTER_S)
        session.execute(insert(WorkerPresence).values(worker_id="gone:1", kind="local", state="ready",
                                                      started_at=old, seen_at=old))
    assert rows(db.url) == {"gone:1": "ready"}
    one = Presence(db, "here:2", kind="local", interval_s=0.1)
    one.start()
    try:
        # the long-gone row is forgotten on start
        wait_until(lambda: rows(db.url) == {"here:2": "warming"}, 30, "only here:2, warming, in the table",
                   step=0.05, details=lambda: str(rows(db.url)))
        # health counts rows refreshed within the test's 2 s staleness: wait, since a refresh can lag on a busy machine
        wait_until(lambda: client.get("/api/health").json()["workers"] == {"warming": 1, "ready": 0}, 30,
                   "health to count one warming worker", details=lambda: str(client.get("/api/health").json()))
        one.ready()
        wait_until(lambda: rows(db.url) == {"here:2": "ready"}, 30, "here:2 ready in the table", step=0.05,
                   details=lambda: str(rows(db.url)))
        wait_until(lambda: client.get("/api/health").json()["workers"] == {"warming": 0, "ready": 1}, 30,
                   "health to count one ready worker", details=lambda: str(client.get("/api/health").json()))
        with db.session() as session:
            assert presence.counts(session, stale_after_s=60) == {"warming": 0, "ready": 1}
    finally:
        one.close()
    assert rows(db.url) == {}

