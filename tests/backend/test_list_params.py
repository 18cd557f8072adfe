"""List and event-list parameters through the API: accepted, stored, run, refused with the item named.

The parameters are the look-alikes of tests/support/extra_params.py (the real ``composite_periods`` and
``schedule`` come with the engine's elements); every request runs on SQLite and PostgreSQL.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from backend_helpers import drain
from fastapi.testclient import TestClient

from backend.execution.worker import Worker
from tests.support.extra_params import registered

SCHEDULE = [{"episode": 2, "change": "new-profiles", "fraction": 0.3}, {"episode": 4, "change": "frequencies"}]
BODY = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 6}


@pytest.fixture(autouse=True)
def _examples(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    with registered(monkeypatch):
        yield


def _refused(client: TestClient, path: str, body: dict) -> dict:
    response = client.post(path, json=body)
    assert response.status_code == 422, response.text
    (detail,) = response.json()["detail"]
    return detail


def test_a_job_takes_a_list_and_an_event_list_and_runs(client: TestClient, worker: Worker) -> None:
    body = BODY | {"params": {"example_periods": [1, 2, 4], "example_schedule": SCHEDULE}}
    response = client.post("/api/jobs", json=body)
    assert response.status_code == 202, response.text
    job = response.json()
    assert job["params"]["example_periods"] == [1, 2, 4]
    assert job["params"]["example_schedule"] == [SCHEDULE[0], SCHEDULE[1] | {"fraction": 0.3}]
    plain = client.post("/api/jobs", json=BODY).json()
    assert plain["config_hash"] != job["config_hash"]
    assert plain["params"]["example_schedule"] == [] and plain["params"]["example_periods"] == []
    assert drain(worker) == 2
    assert client.get(f"/api/jobs/{job['id']}").json()["status"] == "succeeded"


def test_the_schema_describes_the_kinds(client: TestClient) -> None:
    parameters = {p["name"]: p for p in client.get("/api/systems").json()["parameters"]}
    schedule = parameters["example_schedule"]
    assert schedule["kind"] == "events" and [f["name"] for f in schedule["fields"]] == ["episode", "change",
                                                                                         "fraction"]
    assert parameters["example_periods"]["item_kind"] == "int" and parameters["example_periods"]["max_items"] == 50


def test_a_bad_item_or_field_is_named(client: TestClient) -> None:
    bad = [SCHEDULE[0], {"episode": 3, "fraction": 1.5}]
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_schedule": bad}})
    assert detail["field"] == "example_schedule[1].fraction"
    assert detail["loc"] == ["body", "params", "example_schedule", 1, "fraction"]
    assert "must be in [0, 1] (got 1.5)" in detail["msg"]
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_schedule": [{"change": "frequencies"}]}})
    assert detail["field"] == "example_schedule[0].episode" and "is required" in detail["msg"]
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_periods": [1, 0]}})
    assert detail["field"] == "example_periods[1]" and "[1, 1000]" in detail["msg"]
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_periods": [1] * 51}})
    assert detail["field"] == "example_periods" and "at most 50 items (got 51)" in detail["msg"]
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_periods": 3}})
    assert detail["field"] == "example_periods" and "must be a list" in detail["msg"]


def test_the_bodys_size_limits_are_named(client: TestClient) -> None:
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_periods": [1] * 1001}})
    assert detail["field"] == "example_periods" and "at most 1000 items (got 1001)" in detail["msg"]
    event = {f"f{i}": 1 for i in range(33)}
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_schedule": [event]}})
    assert detail["field"] == "example_schedule" and "at most 32 fields (got 33)" in detail["msg"]
    detail = _refused(client, "/api/jobs", BODY | {"params": {"example_schedule": [{"episode": "a\x00"}]}})
    assert detail["field"] == "example_schedule" and "NUL" in detail["msg"]


def test_a_study_holds_a_list_fixed_in_its_base_and_refuses_to_sweep_it(client: TestClient, worker: Worker) -> None:
    study = {"name": "fixed schedule", "method": "grid",
             "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 5,
                      "params": {"example_schedule": SCHEDULE}},
             "space": {"learning_rate": {"values": [0.1, 0.2]}},
             "objective": {"metric": "final_mean", "configuration": "mgrao-max"}}
    response = client.post("/api/studies", json=study)
    assert response.status_code == 202, response.text
    drain(worker)
    jobs = client.get("/api/jobs", params={"limit": 10}).json()["data"]
    assert len(jobs) == 2 and all(j["params"]["example_schedule"][0] == SCHEDULE[0] for j in jobs)
    swept = study | {"space": {"example_schedule": {"values": [0.1]}}}
    detail = _refused(client, "/api/studies", swept)
    assert "example_schedule" in detail["field"] and "a study varies numeric, boolean or choice" in detail["msg"]
    bad_base = study | {"base": study["base"] | {"params": {"example_schedule": [{"episode": -1}]}}}
    detail = _refused(client, "/api/studies", bad_base)
    assert detail["field"] == "base.params.example_schedule[0].episode", detail
