"""End to end: a real uvicorn server (``mgrao serve``) and real worker processes on 127.0.0.1."""

from __future__ import annotations

import csv
import io
import os
import signal
from pathlib import Path

import numpy as np
import pytest
from backend_helpers import JSON, Service
from sqlalchemy import text

from backend.store.db import Database
from mgrao_core import make_spec, run_experiment

pytestmark = pytest.mark.slow


def job(service: Service, job_id: int) -> dict:
    return service.get(f"/api/jobs/{job_id}").json()


# Long enough (about 2 s of work alone) that a poll sees it running before it ends, even under load.
LONG_JOB = {"system": "large", "seeds": 4, "episodes": 10000}


def making_progress(state: dict) -> bool:
    return state["status"] == "running" and state["progress"] > 0


def stored_matches_core(service: Service, job_id: int, **spec: object) -> None:
    text = service.get(f"/api/jobs/{job_id}/episodes").text
    rows = list(csv.DictReader(io.StringIO(text)))
    expected = run_experiment(make_spec(**spec))
    assert len(rows) == sum(len(r.utilities) for r in expected.runs)  # none missing, none duplicated
    keys = {(r["algorithm"], int(r["seed"]), int(r["episode"])) for r in rows}
    assert len(keys) == len(rows)
    stored = {(r["algorithm"], int(r["seed"]), int(r["episode"])): float(r["utility"]) for r in rows}
    for run in expected.runs:
        values = np.array([stored[(run.algorithm, run.seed, e)] for e in range(len(run.utilities))])
        assert np.array_equal(values, run.utilities)


def test_serve_with_workers_runs_cancels_and_stops_cleanly(service: Service) -> None:
    service.start_server(workers=2)
    response = service.post("/api/jobs", json={"system": "multi", "seeds": 3, "episodes": 40, "name": "e2e"})
    assert response.status_code == 202
    job_id = response.json()["id"]
    assert response.headers["location"] == f"/api/jobs/{job_id}"
    service.wait_for(lambda: job(service, job_id)["status"] == "succeeded", what="job to succeed")
    stored_matches_core(service, job_id, system="multi", seeds=3, episodes=40)
    results = service.get(f"/api/jobs/{job_id}/results?points=10").json()
    assert [c["algorithm"] for c in results["configurations"]] == ["uniform", "mgrao-1:1", "mgrao-max"]

    # a long job: seen running with progress, then cancelled
    long = service.post("/api/jobs", json=LONG_JOB).json()
    service.wait_mid_job(long["id"], making_progress, "progress")
    assert service.post(f"/api/jobs/{long['id']}/cancel", headers=JSON).json()["status"] == "cancelled"
    after = service.post("/api/jobs", json={"system": "single", "seeds": 1, "episodes": 10}).json()
    service.wait_for(lambda: job(service, after["id"])["status"] == "succeeded", what="next job")
    assert job(service, long["id"])["status"] == "cancelled"
    assert service.get(f"/api/jobs/{long['id']}/results").status_code == 409

    assert service.server is not None
    service.server.send_signal(signal.SIGTERM)
    assert service.server.wait(timeout=60) == 0
    assert "stopped" in service.logs()


def children(pid: int) -> list[int]:
    """Child processes of ``pid`` (spawned from any of its threads)."""
    tasks = Path(f"/proc/{pid}/task").iterdir()
    return sorted(int(c) for task in tasks for c in (task / "children").read_text().split())


def test_serve_restarts_a_worker_that_died(service: Service) -> None:
    service.start_server(workers=1)
    assert service.server is not None
    (first,) = children(service.server.pid)
    os.kill(first, signal.SIGKILL)
    service.wait_for(lambda: children(service.server.pid) not in ([], [first]), what="a new worker")
    job_id = service.post("/api/jobs", json={"system": "single", "seeds": 1, "episodes": 10}).json()["id"]
    service.wait_for(lambda: job(service, job_id)["status"] == "succeeded", what="the job")


def test_many_workers_run_each_of_200_jobs_exactly_once(service: Service) -> None:
    service.start_server(workers=0)
    for _ in range(3):
        service.start_worker()
    # all three ready before the first job, so that no one of them drains the queue while the others load
    service.wait_for(lambda: (service.get("/api/health").json()["workers"] or {}).get("ready") == 3,
                     timeout=120, what="three ready workers")
    ids = []
    for i in range(200):
        response = service.post("/api/jobs", json={"system": "single", "seeds": [i % 7], "episodes": 3,
                                                   "algorithms": ["uniform", "mgrao-max"]})
        assert response.status_code == 202
        ids.append(response.json()["id"])

    def all_done() -> bool:
        return service.get("/api/jobs?status=succeeded&limit=1").json()["count"] == 200

    service.wait_for(all_done, timeout=120, what="200 jobs")
    db = Database(service.db_url)
    try:
        with db.session() as session:
            attempts = session.execute(text("SELECT attempts, COUNT(*) FROM jobs GROUP BY attempts")).all()
            runs = session.execute(text("SELECT job_id, COUNT(*) FROM runs GROUP BY job_id")).all()
            workers = session.execute(text("SELECT COUNT(DISTINCT worker_id) FROM jobs")).scalar()
    finally:
        db.dispose()
    assert [tuple(row) for row in attempts] == [(1, 200)]  # each job claimed once
    assert sorted(tuple(row) for row in runs) == [(i, 2) for i in ids]
    assert workers >= 2  # the queue really was shared


def test_worker_killed_mid_job_is_requeued_and_finished(service: Service) -> None:
    service.start_server(workers=0)
    spec = LONG_JOB
    job_id = service.post("/api/jobs", json=spec).json()["id"]
    victim = service.start_worker()
    service.wait_mid_job(job_id, making_progress, "the job to make progress")
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    assert job(service, job_id)["status"] == "running"
    service.start_worker()
    service.wait_for(lambda: job(service, job_id)["status"] == "succeeded", timeout=120, what="re-run")
    final = job(service, job_id)
    assert final["attempts"] == 2
    stored_matches_core(service, job_id, **spec)


def test_whole_service_killed_and_restarted_loses_no_acknowledged_job(service: Service) -> None:
    service.start_server(workers=0)
    worker = service.start_worker()
    accepted = []
    short = {"system": "single", "seeds": 2, "episodes": 20}
    for i in range(12):
        body = {**(LONG_JOB if i == 0 else short), "name": f"r{i}"}
        response = service.post("/api/jobs", json=body)
        assert response.status_code == 202
        accepted.append(response.json()["id"])
    service.wait_mid_job(accepted[0], making_progress, "the long job to make progress")
    worker.send_signal(signal.SIGKILL)
    worker.wait()
    service.kill_server()

    service.start_server(workers=2)
    service.wait_for(
        lambda: all(job(service, i)["status"] == "succeeded" for i in accepted), timeout=120,
        what="every acknowledged job",
    )
    listed = service.get("/api/jobs?limit=200").json()
    assert sorted(j["id"] for j in listed["data"]) == sorted(accepted)
    stored_matches_core(service, accepted[0], **LONG_JOB)
