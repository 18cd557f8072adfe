"""The dashboard's light reads on SQLite and PostgreSQL: the jobs' change token, one job's standing in
the queue, and a submission checked without queuing it."""

from __future__ import annotations

from fastapi.testclient import TestClient

from backend.execution.worker import Worker
from tests.backend.backend_helpers import drain

SMALL = {"system": "single", "seeds": 2, "episodes": 5}


def test_the_change_token_moves_with_submits_states_and_deletes_only(client: TestClient, worker: Worker):
    first = client.get("/api/jobs/changes").json()
    assert first["changed"] is True and len(first["token"]) == 16
    assert (first["queued"], first["running"]) == (0, 0)
    idle = client.get("/api/jobs/changes", params={"since": first["token"]})
    assert idle.json() == {"changed": False} and len(idle.content) == 17
    assert idle.headers["cache-control"] == "no-store"

    job = client.post("/api/jobs", json=SMALL).json()
    queued = client.get("/api/jobs/changes", params={"since": first["token"]}).json()
    assert queued["changed"] is True and queued["queued"] == 1
    client.patch(f"/api/jobs/{job['id']}", json={"name": "renamed"})  # labels do not move it
    assert client.get("/api/jobs/changes", params={"since": queued["token"]}).json() == {"changed": False}

    drain(worker)
    done = client.get("/api/jobs/changes", params={"since": queued["token"]}).json()
    assert done["changed"] is True and (done["queued"], done["running"]) == (0, 0)
    deleted = client.request("DELETE", f"/api/jobs/{job['id']}", headers={"Content-Type": "application/json"})
    assert deleted.status_code == 204
    assert client.get("/api/jobs/changes", params={"since": done["token"]}).json()["changed"] is True


def test_a_bad_token_is_refused_naming_since(client: TestClient):
    for bad in ("x" * 17, "not-hex"):
        answer = client.get("/api/jobs/changes", params={"since": bad})
        assert answer.status_code == 422
        assert answer.json()["detail"][0]["field"] == "since"


def test_status_counts_the_queue_ahead_and_the_stored_runs(client: TestClient, worker: Worker):
    jobs = [client.post("/api/jobs", json=SMALL).json() for _ in range(3)]
    standing = [client.get(f"/api/jobs/{j['id']}/status").json() for j in jobs]
    assert [s["ahead"] for s in standing] == [0, 1, 2]
    assert all(s["stored_runs"] == 0 and s["status"] == "queued" for s in standing)
    assert set(standing[0]["workers"]) >= {"warming", "ready"}
    drain(worker)
    after = client.get(f"/api/jobs/{jobs[0]['id']}/status").json()
    assert after["status"] == "succeeded" and after["stored_runs"] == 3 * 2 and after["ahead"] == 0
    assert client.get("/api/jobs/999999/status").status_code == 404


def test_check_answers_200_with_the_refusal_a_submit_would_get(client: TestClient):
    ok = client.post("/api/jobs/check", json=SMALL)
    assert ok.status_code == 200 and ok.json()["valid"] is True and ok.json()["work"] == 2 * 3 * 5 * 10 * 5
    over = {"system": "large", "seeds": 1000, "episodes": 2000}
    checked = client.post("/api/jobs/check", json=over)
    submitted = client.post("/api/jobs", json=over)
    assert checked.status_code == 200 and submitted.status_code == 422
    assert checked.json() == {"valid": False, "detail": submitted.json()["detail"]}
    assert checked.json()["detail"][0]["field"] == "work"
    bad = {"system": "single", "episodes": 0}
    checked, submitted = client.post("/api/jobs/check", json=bad), client.post("/api/jobs", json=bad)
    assert checked.json() == {"valid": False, "detail": submitted.json()["detail"]}
    assert client.get("/api/jobs").json()["count"] == 0  # nothing was queued by a check
