"""Saved systems (``/api/systems/saved``): a base preset plus overrides, run, compared and swept like a preset.

Every test runs on SQLite and PostgreSQL. The list and event-list values are those of the look-alike
parameters of tests/support/extra_params.py.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from backend_helpers import drain
from fastapi.testclient import TestClient

from backend.execution.worker import Worker
from tests.support.extra_params import registered

SCHEDULE = [{"episode": 3, "change": "new-profiles", "fraction": 0.3}]
RUSH = {"name": "rush-hour", "description": "single, 12 parents, a shift at episode 3", "base": "single",
        "params": {"n_parents": 12, "learning_rate": "0.2", "example_schedule": SCHEDULE}}


@pytest.fixture(autouse=True)
def _examples(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    with registered(monkeypatch):
        yield


def _delete(client: TestClient, name: str = "rush-hour") -> int:
    json_type = {"Content-Type": "application/json"}
    return client.request("DELETE", f"/api/systems/saved/{name}", headers=json_type).status_code


def _save(client: TestClient, body: dict = RUSH) -> dict:
    response = client.post("/api/systems/saved", json=body)
    assert response.status_code == 201, response.text
    return response.json()


def test_save_read_list_replace_delete(client: TestClient) -> None:
    saved = _save(client)
    assert saved["params"] == {"n_parents": 12, "learning_rate": 0.2, "example_schedule": SCHEDULE}
    assert saved["resolved"]["n_parents"] == 12 and saved["resolved"]["n_children"] == 1
    assert saved["algorithms"] == ["uniform", "mgrao-1:1", "mgrao-max"]
    assert client.get("/api/systems/saved/rush-hour").json() == saved
    assert [s["name"] for s in client.get("/api/systems/saved").json()] == ["rush-hour"]
    assert [s["name"] for s in client.get("/api/systems").json()["saved"]] == ["rush-hour"]
    assert client.post("/api/systems/saved", json=RUSH).status_code == 409
    replaced = client.put("/api/systems/saved/rush-hour", json=RUSH | {"base": "multi", "params": {}})
    assert replaced.status_code == 200 and replaced.json()["resolved"]["n_children"] == 3
    assert _delete(client) == 204
    assert client.get("/api/systems/saved/rush-hour").status_code == 404
    assert _delete(client) == 404


@pytest.mark.parametrize(("change", "field", "text"), [
    ({"name": "single"}, "name", "a preset's name"),
    ({"name": "Rush Hour"}, "name", "a lowercase letter, then lowercase letters, digits or"),
    ({"base": "rush"}, "base", "single"),
    ({"params": {"n_parents": 0}}, "n_parents", "must be in [1, 1000000]"),
    ({"params": {"example_schedule": [{"episode": 1, "fraction": 7}]}}, "example_schedule[0].fraction", "[0, 1]"),
    ({"params": {"bogus": 1}}, "bogus", "unknown parameter"),
])
def test_a_bad_definition_is_refused_naming_the_field(client: TestClient, change: dict, field: str, text: str) -> None:
    response = client.post("/api/systems/saved", json=RUSH | change)
    assert response.status_code == 422, response.text
    (detail,) = response.json()["detail"]
    assert detail["field"] == field and text in detail["msg"], detail


def test_a_job_of_a_saved_system_is_the_presets_job_with_the_overrides(client: TestClient, worker: Worker) -> None:
    _save(client)
    body = {"algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 5}
    mine = client.post("/api/jobs", json=body | {"system": "rush-hour", "tags": ["x"]})
    assert mine.status_code == 202, mine.text
    same = client.post("/api/jobs", json=body | {"system": "single", "params": RUSH["params"], "seeds": [2, 3]}).json()
    mine = mine.json()
    assert mine["system"] == "single" and mine["tags"] == ["x", "system:rush-hour"]
    assert mine["config_hash"] == same["config_hash"] and mine["params"] == same["params"]
    on_top = client.post("/api/jobs", json=body | {"system": "rush-hour", "params": {"n_parents": 14}}).json()
    assert on_top["params"]["n_parents"] == 14 and on_top["params"]["example_schedule"] == SCHEDULE
    checked = client.post("/api/jobs/check", json=body | {"system": "rush-hour"}).json()
    assert checked["valid"] is True
    assert drain(worker) == 3
    compared = client.get("/api/compare", params={"jobs": f"{mine['id']},{same['id']}"}).json()
    groups = compared if isinstance(compared, list) else compared.get("groups", compared.get("data"))
    pooled = [c for c in groups if c["algorithm"] == "mgrao-max"]
    assert len(pooled) == 1 and pooled[0]["job_ids"] == [mine["id"], same["id"]]


def test_an_unknown_system_names_the_saved_ones(client: TestClient) -> None:
    response = client.post("/api/jobs", json={"system": "nowhere", "seeds": 1, "episodes": 2})
    assert response.status_code == 422
    (detail,) = response.json()["detail"]
    assert detail["field"] == "system" and "saved system" in detail["msg"]


def test_a_study_sweeps_a_saved_system(client: TestClient, worker: Worker) -> None:
    _save(client)
    study = {"method": "grid", "base": {"system": "rush-hour", "algorithms": ["uniform", "mgrao-max"], "seeds": 2,
                                        "episodes": 4, "params": {"n_parents": 10}},
             "space": {"learning_rate": {"values": [0.1, 0.3]}},
             "objective": {"metric": "final_mean", "configuration": "mgrao-max"}}
    response = client.post("/api/studies", json=study)
    assert response.status_code == 202, response.text
    assert response.json()["definition"]["base"]["system"] == "single"
    drain(worker)
    jobs = client.get("/api/jobs", params={"limit": 10}).json()["data"]
    assert len(jobs) == 2
    assert all(j["params"]["example_schedule"] == SCHEDULE and j["params"]["n_parents"] == 10 for j in jobs)
    missing = client.post("/api/studies", json=study | {"base": study["base"] | {"system": "nowhere"}})
    assert missing.status_code == 422 and missing.json()["detail"][0]["field"] == "base.system"


def test_a_study_over_several_systems_takes_saved_ones_by_name(client: TestClient, worker: Worker) -> None:
    _save(client)  # rush-hour: single with 12 parents; its jobs run beside single's, whose preset it shares
    study = {"method": "grid", "base": {"system": ["single", "rush-hour"], "algorithms": ["uniform", "mgrao-max"],
                                        "seeds": 2, "episodes": 4},
             "space": {"learning_rate": {"values": [0.1, 0.3]}},
             "objective": {"metric": "final_mean", "configuration": "mgrao-max", "system": "rush-hour"}}
    response = client.post("/api/studies", json=study)
    assert response.status_code == 202, response.text
    definition = response.json()["definition"]
    assert definition["base"]["system"][0] == "single"
    assert definition["base"]["system"][1]["name"] == "rush-hour"
    assert definition["base"]["system"][1]["system"] == "single"
    assert definition["base"]["system"][1]["params"]["n_parents"] == 12
    assert definition["objective"]["system"] == "rush-hour"
    study_id = response.json()["study"]["id"]
    for _ in range(50):
        drain(worker)
        answer = client.get(f"/api/studies/{study_id}").json()
        if answer["study"]["status"] != "running":
            break
    assert answer["study"]["trials"] == {"succeeded": 2}, answer["study"]
    for trial in answer["trials"]:
        jobs = [client.get(f"/api/jobs/{i}").json() for i in trial["job_ids"]]
        assert sorted(j["params"]["n_parents"] for j in jobs) == [10, 12]
        assert {j["system"] for j in jobs} == {"single"}
        [rush] = [j for j in jobs if j["params"]["n_parents"] == 12]
        assert "system:rush-hour" in rush["tags"] and rush["params"]["example_schedule"] == SCHEDULE
        assert rush["params"]["learning_rate"] == trial["params"]["learning_rate"]
        results = client.get(f"/api/jobs/{rush['id']}/results").json()
        [best] = [c for c in results["configurations"] if c["algorithm"] == "mgrao-max"]
        assert trial["value"] == pytest.approx(best["summary"]["final_mean"], rel=1e-12)  # rush-hour's, not single's
    missing = client.post("/api/studies", json=study | {"base": study["base"] | {"system": ["single", "nowhere"]}})
    assert missing.status_code == 422, missing.text
    assert missing.json()["detail"][0]["loc"] == ["body", "base", "system", 1]
    twice = client.post("/api/studies", json=study | {"base": study["base"] | {"system": ["rush-hour", "rush-hour"]}})
    assert twice.status_code == 422 and twice.json()["detail"][0]["field"] == "base.system", twice.text


def test_the_runs_list_names_and_filters_a_saved_systems_jobs(client: TestClient) -> None:
    """Issue 30, point 7: the System filter knew presets only, and a saved system's job showed its base's name."""
    assert client.post("/api/systems/saved", json={"name": "rush", "base": "single",
                                                  "params": {"n_parents": 12}}).status_code == 201
    mine = client.post("/api/jobs", json={"system": "rush", "seeds": 1, "episodes": 2}).json()
    plain = client.post("/api/jobs", json={"system": "single", "seeds": 1, "episodes": 2}).json()
    assert mine["saved_system"] == "rush" and mine["system"] == "single" and plain["saved_system"] is None

    def listed(system: str) -> list[int]:
        return [j["id"] for j in client.get("/api/jobs", params={"system": system}).json()["data"]]

    assert listed("rush") == [mine["id"]]
    assert listed("single") == [plain["id"]]  # the preset's own jobs, not a saved system's based on it
    assert listed("nothing-saved") == []
