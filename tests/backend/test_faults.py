"""Fault injection against real processes: the database made read-only, moved, deleted or locked.

Run alone with ``python -m pytest tests/backend/test_faults.py -v``. Each test starts a real
``mgrao serve`` (and, where it says so, a standalone ``mgrao worker``) on a real SQLite file,
injects a fault, and counts: submissions acknowledged (202) against jobs stored, health answers,
and processes still alive. A read-only file is made with ``chattr +i`` (which binds root too);
where the file system has no such flag the tests that need it skip, saying so.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import sqlite3
import subprocess
import time
from pathlib import Path

import pytest
from backend_helpers import JSON, Service, children

pytestmark = pytest.mark.slow
SMALL = {"system": "single", "seeds": 2, "episodes": 10}


@pytest.fixture
def service(tmp_path: Path):
    """A service on a SQLite file: these faults are done to the file (PostgreSQL's are in test_postgres_faults.py)."""
    svc = Service(tmp_path)
    yield svc
    svc.stop()


def _chattr_works(tmp_path: Path) -> bool:
    probe = tmp_path / "chattr-probe"
    probe.write_text("x")
    try:
        done = subprocess.run(["chattr", "+i", str(probe)], capture_output=True, check=False)
    except FileNotFoundError:
        return False
    subprocess.run(["chattr", "-i", str(probe)], capture_output=True, check=False)
    return done.returncode == 0


@pytest.fixture
def immutable(tmp_path: Path):
    """``immutable(path, True/False)``: set or clear the immutable flag; cleared at the end."""
    if not _chattr_works(tmp_path):
        pytest.skip("chattr +i is not supported here (needs ext4/xfs-like flags and CAP_LINUX_IMMUTABLE)")
    flagged: list[Path] = []

    def set_flag(path: Path, on: bool) -> None:
        subprocess.run(["chattr", "+i" if on else "-i", str(path)], check=True)
        (flagged.append if on else flagged.remove)(path)

    yield set_flag
    for path in flagged:
        subprocess.run(["chattr", "-i", str(path)], check=False)


def _fast_faults(service: Service) -> Service:
    service.env["MGRAO_DB_BUSY_TIMEOUT_S"] = "1"
    return service


def _stored_jobs(db_file: Path) -> int:
    with sqlite3.connect(f"file:{db_file}?mode=ro", uri=True) as connection:
        return connection.execute("SELECT count(*) FROM jobs").fetchone()[0]


def _submit(service: Service, count: int) -> tuple[int, list[int]]:
    """POST ``count`` jobs; (acknowledged, every status code)."""
    codes = [service.post("/api/jobs", json=SMALL).status_code for _ in range(count)]
    return codes.count(202), codes


def _accepted(service: Service, body: dict = SMALL) -> int:
    """POST a job outside a fault window and return its id. A 503 saying the database is locked means a
    worker held the write lock past these tests' 1 s busy timeout (a loaded disk); nothing was stored, so
    that POST is repeated, a few times. Any other answer, a 503 for the fault itself among them, fails."""
    for _ in range(5):
        response = service.post("/api/jobs", json=body)
        if response.status_code != 503 or "locked" not in response.text:
            break
        time.sleep(0.5)
    assert response.status_code == 202, response.text
    return response.json()["id"]


def _alive(*processes: subprocess.Popen | None) -> bool:
    return all(p is not None and p.poll() is None for p in processes)


def _wait_succeeded(service: Service, job_id: int) -> None:
    service.wait_for(lambda: service.get(f"/api/jobs/{job_id}").json()["status"] == "succeeded", what=f"job {job_id}")


def _logged(service: Service, pattern: str, what: str) -> None:
    """Wait until a process's log has ``pattern`` (a regular expression). A database call that fails is logged at its
    first failure, and the tries after it once one goes through (:class:`backend.store.retry.OutageLog`): the
    evidence that a process met the fault and kept trying, where the tests slept a few seconds before."""
    service.wait_for(lambda: re.search(pattern, service.logs()), timeout=60, what=what, step=0.05)


def test_read_only_database(service: Service, immutable) -> None:
    _fast_faults(service)
    service.start_server(workers=2)
    db_file = Path(service.db_url.removeprefix("sqlite:///"))
    first = _accepted(service)
    _wait_succeeded(service, first)
    running = _accepted(service, {"system": "large", "seeds": 20, "episodes": 3000})
    service.wait_for(lambda: service.get(f"/api/jobs/{running}").json()["status"] == "running", what="running")
    immutable(db_file, True)

    health = service.get("/api/health")
    assert health.status_code == 503 and "readonly" in health.json()["database"], health.text
    acknowledged, codes = _submit(service, 10)
    assert acknowledged == 0 and set(codes) == {503}
    refused = service.post("/api/jobs", json=SMALL)
    assert refused.headers["retry-after"] and "was not queued" in refused.json()["detail"]
    assert service.post(f"/api/jobs/{first}/cancel", headers=JSON).status_code in (409, 503)
    assert service.get("/api/jobs").status_code == 200  # reading still works
    time.sleep(3)  # workers keep failing to heartbeat and store meanwhile
    assert _alive(service.server) and service.get("/api/health").status_code == 503

    immutable(db_file, False)
    service.wait_for(lambda: service.get("/api/health").status_code == 200, what="health after the fault")
    _wait_succeeded(service, _accepted(service))
    _wait_succeeded(service, running)  # the job that ran through the fault finishes too
    assert _alive(service.server)
    assert _stored_jobs(db_file) == 3  # exactly the acknowledged ones


def test_deleted_database_directory(tmp_path: Path) -> None:
    directory = tmp_path / "data"
    directory.mkdir()
    service = _fast_faults(Service(tmp_path))
    service.db_url = f"sqlite:///{directory / 'mgrao.db'}"
    service.env["MGRAO_DATABASE_URL"] = service.db_url
    try:
        service.start_server(workers=1)
        _wait_succeeded(service, _accepted(service))
        shutil.rmtree(directory)
        health = service.get("/api/health")
        assert health.status_code == 503 and "is missing (moved or deleted)" in health.json()["database"], health.text
        acknowledged, codes = _submit(service, 13)
        assert acknowledged == 0 and set(codes) == {503}
        _logged(service, r"worker \S+ polling the queue failed \(unable to open database file\)",
                "the worker's poll to fail on the lost file")
        _logged(service, r"refreshing worker \S+ in the workers table failed \(unable to open database file\)",
                "the worker's refresh of its row to fail on the lost file")
        assert _alive(service.server) and not directory.exists()  # nothing recreated the lost file
    finally:
        service.stop()


def test_moved_database_file(service: Service) -> None:
    _fast_faults(service)
    service.start_server(workers=1)
    db_file = Path(service.db_url.removeprefix("sqlite:///"))
    _wait_succeeded(service, _accepted(service))
    moved = db_file.with_name("moved.db")
    db_file.rename(moved)
    health = service.get("/api/health")
    assert health.status_code == 503 and "is missing (moved or deleted)" in health.json()["database"], health.text
    acknowledged, codes = _submit(service, 5)
    assert acknowledged == 0 and set(codes) == {503}
    moved.rename(db_file)
    service.wait_for(lambda: service.get("/api/health").status_code == 200, what="health after moving back")
    _accepted(service)
    assert _stored_jobs(db_file) == 2 and _alive(service.server)


def test_write_lock_held_by_another_process(service: Service) -> None:
    _fast_faults(service)
    service.start_server(workers=0)
    lone = service.start_worker()
    db_file = Path(service.db_url.removeprefix("sqlite:///"))
    job = _accepted(service)
    _wait_succeeded(service, job)
    queued = _accepted(service)
    service.wait_for(lambda: service.get(f"/api/jobs/{queued}").json()["status"] == "succeeded", what="second job")
    locker = sqlite3.connect(db_file, isolation_level=None, timeout=10)
    locker.execute("BEGIN IMMEDIATE")
    try:
        refused = service.post("/api/jobs", json=SMALL)
        assert refused.status_code == 503 and refused.headers["content-type"].startswith("application/json")
        assert "locked" in refused.json()["detail"] and "was not queued" in refused.json()["detail"]
        assert service.get("/api/health").status_code == 503
        _logged(service, rf"refreshing worker \S+:{lone.pid} in the workers table failed \(database is locked\)",
                "the standalone worker to write into the lock (its row's refresh, after the 1 s busy timeout)")
        assert _alive(service.server, lone)
    finally:
        locker.execute("ROLLBACK")
        locker.close()
    _wait_succeeded(service, _accepted(service))
    assert _alive(service.server, lone)
    assert _stored_jobs(db_file) == 3


def test_a_worker_started_on_a_read_only_database_waits_and_then_works(service: Service, immutable) -> None:
    _fast_faults(service)
    service.start_server(workers=0)
    db_file = Path(service.db_url.removeprefix("sqlite:///"))
    job = _accepted(service)
    immutable(db_file, True)
    lone = service.start_worker()
    _logged(service, rf"worker \S+:{lone.pid} polling the queue failed \(attempt to write a readonly database\)",
            "the worker's claim to fail on the read-only file")
    assert _alive(lone)  # the claim failed: the worker retries instead of exiting
    assert service.get(f"/api/jobs/{job}").json()["status"] == "queued"
    immutable(db_file, False)
    _wait_succeeded(service, job)
    assert _alive(lone, service.server)
    _logged(service, rf"worker \S+:{lone.pid} polling the queue goes through again",  # retried, logged
            "the worker to log that its claims go through again")  # once the batch it claimed is stored


def test_a_restarted_worker_does_not_bring_back_a_missing_database(service: Service) -> None:
    _fast_faults(service)
    service.start_server(workers=1)
    db_file = Path(service.db_url.removeprefix("sqlite:///"))
    _wait_succeeded(service, _accepted(service))
    moved = db_file.with_name("moved.db")
    db_file.rename(moved)
    for pid in children(service.server.pid):  # the supervisor restarts the worker it loses
        os.kill(pid, signal.SIGKILL)
    service.wait_for(lambda: len(children(service.server.pid)) >= 1 and not db_file.exists(), what="restart")
    _logged(service, r"migrating the database failed \(the database file \S+ does not exist",
            "the new worker's migration to fail on the missing file")
    assert not db_file.exists()  # nothing recreated it empty
    assert service.get("/api/health").status_code == 503
    acknowledged, codes = _submit(service, 5)
    assert acknowledged == 0 and set(codes) == {503}
    moved.rename(db_file)
    service.wait_for(lambda: service.get("/api/health").status_code == 200, what="health after moving back")
    later = _accepted(service)
    _wait_succeeded(service, later)  # the restarted worker found the file and works
    assert "migrating the database goes through again" in service.logs()  # retried, not given up
    assert _stored_jobs(db_file) == 2


@pytest.fixture
def small_disk(tmp_path: Path):
    """A 32 MiB tmpfs mounted at ``tmp_path/disk`` (unmounted at the end); skips where mounting is not allowed."""
    mount = tmp_path / "disk"
    mount.mkdir()
    try:
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=32m,mode=0755", "tmpfs", str(mount)],
                              capture_output=True, text=True, check=False, timeout=30)
    except FileNotFoundError:
        pytest.skip("no mount command on this machine")
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here (needs root and CAP_SYS_ADMIN): {done.stderr.strip()}")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], capture_output=True, check=False, timeout=30)


def _fill(disk: Path, leave_bytes: int = 0) -> Path:
    """Write a file on ``disk`` until at most ``leave_bytes`` are free (ENOSPC ends it at 0); its path."""
    filler = disk / "filler"
    block = b"\0" * 1024**2
    with open(filler, "wb", buffering=0) as out:
        while (free := shutil.disk_usage(disk).free) > leave_bytes:
            try:
                out.write(block[: max(4096, min(len(block), free - leave_bytes))])
            except OSError:  # ENOSPC: nothing left
                break
    return filler


def test_a_full_disk_answers_503_on_health_and_submissions_and_loses_nothing(tmp_path: Path, small_disk: Path) -> None:
    # the issue's probe: health said "ok" on 400 of 400 polls while every submission got 503 "database or disk
    # is full"; a write that rolls back never needs new space, so only the free space tells
    service = Service(tmp_path, db_url=f"sqlite:///{small_disk / 'service.db'}")  # its logs stay on tmp_path
    service.env["MGRAO_MIN_FREE_MIB"] = "4"
    try:
        service.start_server(workers=1)
        db_file = small_disk / "service.db"
        _wait_succeeded(service, _accepted(service))
        running = _accepted(service, {"system": "large", "seeds": 20, "episodes": 3000})
        service.wait_for(lambda: service.get(f"/api/jobs/{running}").json()["status"] == "running", what="running")

        filler = _fill(small_disk)  # the disk completely full
        polls = [service.get("/api/health") for _ in range(20)]
        assert {p.status_code for p in polls} == {503}, [p.text for p in polls if p.status_code != 503][:1]
        body = polls[-1].json()
        assert "full" in body["database"] and "MGRAO_MIN_FREE_MIB" in body["database"], body
        assert body["queued"] is None and body["running"] is None, body  # unknown, not an empty queue
        acknowledged, codes = _submit(service, 10)
        assert acknowledged == 0 and set(codes) == {503}, codes
        study = service.post("/api/studies", json={
            "name": "full disk", "method": "grid", "base": {"system": "single", "seeds": 2, "episodes": 10},
            "space": {"learning_rate": {"values": [0.1, 0.2]}},
            "objective": {"configuration": "mgrao-max", "metric": "final_mean", "direction": "maximize"}})
        assert study.status_code == 503 and "MGRAO_MIN_FREE_MIB" in study.text, study.text

        filler.unlink()
        _fill(small_disk, leave_bytes=2 * 1024**2)  # some room, but less than the reserve
        nearly = service.get("/api/health")
        assert nearly.status_code == 503 and "nearly" in nearly.json()["database"], nearly.text
        assert service.post("/api/jobs", json=SMALL).status_code == 503
        listing = service.get("/api/jobs")  # on a disk completely full SQLite's WAL index cannot grow, reads too
        assert listing.status_code == 200 and listing.json()["count"] == 2, listing.text  # fail; here they work

        filler.unlink()
        service.wait_for(lambda: service.get("/api/health").status_code == 200, what="health after space was freed")
        _wait_succeeded(service, _accepted(service))
        _wait_succeeded(service, running)  # the job that ran through the full disk finishes, its runs whole
        configurations = service.get(f"/api/jobs/{running}/results").json()["configurations"]
        assert configurations and all(c["seeds_done"] == 20 for c in configurations), configurations
        assert _stored_jobs(db_file) == 3  # exactly the acknowledged ones
    finally:
        service.stop()
