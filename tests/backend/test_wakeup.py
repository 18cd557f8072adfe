"""Wake-ups (backend/wakeup.py): workers woken on submit, studies handed to the API's driver; polls the fallback."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
from backend_helpers import Service
from sqlalchemy import update

from backend import wakeup
from backend.services import studies
from backend.store.db import Database
from backend.store.models import Job, Study, Trial
from mgrao_core.search import make_plan

SMALL = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 1, "episodes": 10}


def test_a_listener_is_woken_by_a_send_and_a_send_to_no_one_says_so(tmp_path: Path,
                                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(wakeup.ENV, str(tmp_path))
    assert not wakeup.send("nobody")  # no socket: the caller falls back (advances itself, or polls)
    listener = wakeup.Listener("worker-1")
    try:
        assert wakeup.wake_workers() == 1
        assert listener.wait(5) == [b"!"]
        t = time.monotonic()
        assert listener.wait(0.05) == []  # nothing more: the wait ends at its timeout
        assert time.monotonic() - t >= 0.04
    finally:
        listener.close()
    assert wakeup.wake_workers() == 0 and not (tmp_path / "worker-1").exists()


def test_without_a_driver_listening_a_worker_advances_the_study_itself(db: Database, tmp_path: Path,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(wakeup.ENV, str(tmp_path))  # a directory, but no API bound to it
    study_id = studies.create_study(db, plan=make_plan({
        "name": "fallback", "method": "grid", "base": SMALL,
        "space": {"learning_rate": {"low": 0.01, "high": 0.5, "steps": 2}},
        "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform"}, "max_in_flight": 1}))
    with db.write() as session:  # the first trial's job "ended": failed, so that the study has something to record
        job_id = session.scalar(update(Job).where(Job.study_id == study_id).values(status="failed", error="x")
                                .returning(Job.id))
    studies.hand_over_or_advance(db, [job_id])
    with db.session() as session:
        trials = dict(session.query(Trial.number, Trial.status).filter(Trial.study_id == study_id).all())
        assert trials == {0: "failed", 1: "queued"}  # recorded and the next trial made, here and now
        assert session.get(Study, study_id).status == "running"


@pytest.mark.slow
def test_under_serve_jobs_and_studies_move_on_wake_ups_not_polls(service: Service) -> None:
    # polls far apart: only wake-ups can run these within the deadlines below
    service.env |= {"MGRAO_POLL_S": "30", "MGRAO_STUDY_POLL_S": "600"}
    service.start_server(workers=1)
    service.wait_for(lambda: service.get("/api/health").json().get("workers", {}).get("ready", 0) >= 1,
                     timeout=120, what="the worker ready")
    time.sleep(0.5)  # the worker idle, in its 30 s wait
    job_id = service.post("/api/jobs", json=SMALL).json()["id"]
    service.wait_for(lambda: service.get(f"/api/jobs/{job_id}").json()["status"] == "succeeded", timeout=15,
                     what="the submitted job succeeded, woken long before the worker's next poll", step=0.05)
    study = {"name": "woken", "method": "random", "base": SMALL,
             "space": {"learning_rate": {"low": 0.01, "high": 0.5, "log": True}},
             "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform"},
             "max_trials": 40, "max_in_flight": 5}  # eight rounds of trials, each made by a hand-over
    study_id = service.post("/api/studies", json=study).json()["study"]["id"]
    status = lambda: service.get(f"/api/studies/{study_id}", params={"trials": "false"}).json()["study"]  # noqa: E731
    service.wait_for(lambda: status()["status"] == "finished", timeout=60,
                     what="the study finished on hand-overs and wake-ups (the driver's own round is 600 s away)")
    assert status()["trials"] == {"succeeded": 40}


def test_a_killed_serves_wake_up_directory_is_swept_by_the_next_serve(service: Service, tmp_path: Path) -> None:
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    service.env |= {"TMPDIR": str(tmp)}  # tempfile.gettempdir() in the served processes
    service.start_server(workers=0)
    first = sorted(tmp.glob(f"{wakeup.DIR_PREFIX}*"))
    assert [d.name.split("-")[2] for d in first] == [str(service.server.pid)], first
    service.kill_server()  # SIGKILL: no chance to remove it
    assert first[0].is_dir()
    mine = tmp / f"{wakeup.DIR_PREFIX}{os.getpid()}-live"  # a live process's: left alone
    mine.mkdir()
    service.start_server(workers=0)
    left = sorted(tmp.glob(f"{wakeup.DIR_PREFIX}*"))
    assert not first[0].exists() and mine in left and len(left) == 2, left
    assert str(service.server.pid) in {d.name.split("-")[2] for d in left}
