"""``GET /api/jobs/{id}/weights``: one seed's final weights, bit for bit the core's, and its errors."""

from __future__ import annotations

import numpy as np
from backend_helpers import drain
from fastapi.testclient import TestClient

from backend.execution.worker import Worker
from mgrao_core import make_spec, run_experiment

ALGORITHMS = ["uniform", "oracle", "mgrao-1:1", "mgrao-max"]


def test_one_seed_is_that_seeds_runs_bit_for_bit(client: TestClient, worker: Worker) -> None:
    body = {"system": "multi", "algorithms": ALGORITHMS, "seeds": [7, 3, 11], "episodes": 12}
    job = client.post("/api/jobs", json=body).json()
    drain(worker)
    expected = run_experiment(make_spec("multi", ALGORITHMS, [7, 3, 11], 12))

    first = client.get(f"/api/jobs/{job['id']}/weights").json()
    assert first["seed"] == 7 and first["seeds"] == [7, 3, 11]  # the job's order, its first seed by default
    answer = client.get(f"/api/jobs/{job['id']}/weights?seed=3").json()
    assert answer["seed"] == 3 and [c["algorithm"] for c in answer["configurations"]] == ALGORITHMS
    for config in answer["configurations"]:
        run = next(r for r in expected.runs if r.algorithm == config["algorithm"] and r.seed == 3)
        assert np.array_equal(np.array(config["combined"]), run.combined_weights)
        if config["algorithm"] in ("uniform", "oracle"):
            assert config["groups"] == []
        else:
            assert np.array_equal(np.array(config["groups"]), run.group_weights)
    # each seed's own structure: the oracle's allocations differ between seeds, and the mean is neither
    oracle = {seed: np.array(next(c for c in client.get(f"/api/jobs/{job['id']}/weights?seed={seed}").json()
                                  ["configurations"] if c["algorithm"] == "oracle")["combined"]) for seed in (7, 3)}
    assert not np.allclose(oracle[7], oracle[3])
    mean = next(c for c in client.get(f"/api/jobs/{job['id']}/results").json()["configurations"]
                if c["algorithm"] == "oracle")["weights"]["combined"]
    assert not np.allclose(mean, oracle[3])


def test_a_seed_not_of_the_job_or_not_stored_is_refused(client: TestClient, worker: Worker) -> None:
    job = client.post("/api/jobs", json={"system": "single", "seeds": 2, "episodes": 5}).json()
    assert client.get(f"/api/jobs/{job['id']}/weights").status_code == 409  # nothing stored yet
    assert worker.run_once()  # the job (small jobs are claimed in batches: the later one is submitted after)
    queued = client.post("/api/jobs", json={"system": "single", "seeds": 2, "episodes": 5, "name": "later"}).json()
    wrong = client.get(f"/api/jobs/{job['id']}/weights?seed=5")
    assert wrong.status_code == 422 and "seed" in wrong.text and "0, 1" in wrong.text
    for bad in ("-1", "4294967296", "abc", "1.5"):
        response = client.get(f"/api/jobs/{job['id']}/weights?seed={bad}")
        assert response.status_code == 422 and "seed" in response.text, bad
    assert client.get(f"/api/jobs/{queued['id']}/weights?seed=0").status_code == 409
    assert client.get("/api/jobs/999999/weights").status_code == 404


def test_adaptive_groups_give_their_recorded_membership(client: TestClient, worker: Worker) -> None:
    algorithms = ["uniform", "mgrao-5:1", "mgrao-adaptive:5"]
    body = {"system": "large", "algorithms": algorithms, "seeds": [2], "episodes": 25, "params": {"regroup_every": 5}}
    job = client.post("/api/jobs", json=body).json()
    assert job.get("id"), job
    drain(worker)
    expected = run_experiment(make_spec("large", algorithms, [2], 25, {"regroup_every": 5})).runs[-1]
    by = {c["algorithm"]: c for c in client.get(f"/api/jobs/{job['id']}/weights").json()["configurations"]}
    assert by["uniform"]["membership"] is None and by["mgrao-5:1"]["membership"] is None
    membership = by["mgrao-adaptive:5"]["membership"]
    assert membership["every"] == 5
    assert np.array_equal(np.array(membership["children"]), expected.membership)
    assert np.array(membership["children"]).shape == (1, 5, 50)  # episode 0 and the regroups at 5, 10, 15, 20


def test_several_resources_answer_one_set_of_weights_per_resource(client: TestClient, worker: Worker) -> None:
    # resource-major storage: the answer's combined and groups are the first resource's (as before), and
    # resources gives each one's, bit for bit the core's; with one resource resources is null
    algorithms = ["uniform", "oracle", "mgrao-1:1", "mgrao-max"]
    params = {"resource_credit": "by-share"}
    job = client.post("/api/jobs", json={"system": "multi-resource", "algorithms": algorithms, "seeds": [4, 1],
                                         "episodes": 10, "params": params}).json()
    assert job.get("id"), job
    drain(worker)
    expected = run_experiment(make_spec("multi-resource", algorithms, [4, 1], 10, overrides=params))
    answer = client.get(f"/api/jobs/{job['id']}/weights?seed=1").json()
    for config in answer["configurations"]:
        run = next(r for r in expected.runs if r.algorithm == config["algorithm"] and r.seed == 1)
        assert np.array_equal(np.array(config["combined"]), run.combined_weights)
        assert [r["resource"] for r in config["resources"]] == [0, 1]
        for r, resource in enumerate(config["resources"]):
            assert np.array_equal(np.array(resource["combined"]), run.resource_weights[r])
            if config["algorithm"].startswith("mgrao"):
                assert np.array_equal(np.array(resource["groups"]), run.resource_group_weights[r])
            else:
                assert resource["groups"] == []
    results = client.get(f"/api/jobs/{job['id']}/results").json()["configurations"]
    mean = next(c for c in results if c["algorithm"] == "mgrao-max")["weights"]
    runs = [r for r in expected.runs if r.algorithm == "mgrao-max"]
    assert np.allclose(mean["resources"][1]["groups"], np.mean([r.resource_group_weights[1] for r in runs], axis=0))
    one = client.post("/api/jobs", json={"system": "single", "algorithms": ["mgrao-1:1"], "seeds": [0],
                                         "episodes": 5}).json()
    drain(worker)
    assert "resources" not in client.get(f"/api/jobs/{one['id']}/weights").json()["configurations"][0]
