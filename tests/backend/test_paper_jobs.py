"""Finding the paper's experiment by what it is (``config_hash``), not by a tag a clone inherits, and
each seed's paired % from uniform in the results (the values behind the summary's mean and interval)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from backend_helpers import drain
from fastapi.testclient import TestClient

from backend.execution.worker import Worker
from mgrao_core import PRESETS, final_utilities
from mgrao_core.presets import PAPER_SYSTEMS


def submit(client: TestClient, **body: object) -> dict:
    response = client.post("/api/jobs", json={"system": "single", "seeds": 2, "episodes": 100, **body})
    assert response.status_code == 202, response.text
    return response.json()


def test_the_paper_configuration_is_listed_whatever_its_tags(client: TestClient) -> None:
    systems = {s["name"]: s for s in client.get("/api/systems").json()["systems"]}
    assert len({systems[name]["paper_config_hash"] for name in PAPER_SYSTEMS}) == len(PAPER_SYSTEMS)
    assert all(len(systems[name]["paper_config_hash"]) == 64 for name in PAPER_SYSTEMS)
    paper = systems["single"]["paper_config_hash"]
    plain = submit(client, name="no tag at all")
    same = submit(client, params={"learning_rate": PRESETS["single"].params.as_dict()["learning_rate"]},
                  algorithms=["uniform", "mgrao-max"], seeds=[7, 8, 9])  # the preset's own value: the same experiment
    changed = submit(client, tags=["paper"], params={"learning_rate": 0.5})  # a tagged clone with a change
    shorter = submit(client, tags=["paper"], episodes=20)
    other = submit(client, system="multi", tags=["paper"])
    assert plain["config_hash"] == same["config_hash"] == paper
    listed = client.get("/api/jobs", params={"config_hash": paper}).json()
    assert {j["id"] for j in listed["data"]} == {plain["id"], same["id"]} and listed["count"] == 2
    assert {changed["config_hash"], shorter["config_hash"], other["config_hash"]}.isdisjoint({paper})
    assert client.get("/api/jobs", params={"config_hash": paper, "tag": "paper"}).json()["count"] == 0
    multi = client.get("/api/jobs", params={"config_hash": systems["multi"]["paper_config_hash"]}).json()
    assert [j["id"] for j in multi["data"]] == [other["id"]]


def test_a_system_beyond_the_paper_has_no_paper_configuration(client: TestClient) -> None:
    systems = {s["name"]: s for s in client.get("/api/systems").json()["systems"]}
    beyond = [name for name in PRESETS if name not in PAPER_SYSTEMS]
    assert {"drift", "bursty"} <= set(beyond)
    for name in beyond:
        assert systems[name]["paper_config_hash"] is None, name
        assert systems[name]["paper"] == {} and systems[name]["paper_pct_of_max"] == {}
    # a drift job still has its own config_hash, found like any other configuration's
    job = submit(client, system="drift", seeds=1, episodes=10)
    assert len(job["config_hash"]) == 64
    assert client.get("/api/jobs", params={"config_hash": job["config_hash"]}).json()["count"] == 1


@pytest.mark.parametrize("value", ["abc", "A" * 64, "g" * 64, "0" * 65])
def test_a_malformed_config_hash_is_refused_naming_the_field_and_its_form(client: TestClient, value: str) -> None:
    response = client.get("/api/jobs", params={"config_hash": value})
    assert response.status_code == 422, response.text
    [detail] = response.json()["detail"]
    assert detail["field"] == "config_hash" and detail["loc"] == ["query", "config_hash"]
    assert "64" in detail["msg"], detail


def test_results_carry_each_seeds_paired_pct_from_uniform(client: TestClient, worker: Worker) -> None:
    job = submit(client, seeds=[5, 3, 11, 2], episodes=15)
    assert drain(worker) == 1
    assert all("pct_by_seed" not in c for c in client.get(f"/api/jobs/{job['id']}/results").json()["configurations"])
    refused = client.get(f"/api/jobs/{job['id']}/results?pct_by_seed=maybe")
    assert refused.status_code == 422 and refused.json()["detail"][0]["field"] == "pct_by_seed", refused.text
    results = client.get(f"/api/jobs/{job['id']}/results?pct_by_seed=true").json()
    episodes = json.loads(client.get(f"/api/jobs/{job['id']}/episodes?format=json").content)
    finals: dict[str, dict[int, float]] = {}
    for algorithm in job["algorithms"]:
        for seed in job["seeds"]:
            values = np.array([e["utility"] for e in episodes if e["algorithm"] == algorithm and e["seed"] == seed])
            finals.setdefault(algorithm, {})[seed] = float(final_utilities(values)[0])
    for config in results["configurations"]:
        algorithm = config["algorithm"]
        per_seed = config["pct_by_seed"]
        assert [p["seed"] for p in per_seed] == [5, 3, 11, 2]  # the job's order
        for p in per_seed:
            expected = 100.0 * (finals[algorithm][p["seed"]] / finals["uniform"][p["seed"]] - 1.0)
            assert p["pct_from_uniform"] == pytest.approx(expected, rel=1e-12, abs=1e-12)
        mean = float(np.mean([p["pct_from_uniform"] for p in per_seed]))
        assert mean == pytest.approx(config["summary"]["pct_from_uniform"], rel=1e-12, abs=1e-12)
    uniform = next(c for c in results["configurations"] if c["algorithm"] == "uniform")
    assert all(p["pct_from_uniform"] == 0.0 for p in uniform["pct_by_seed"])
