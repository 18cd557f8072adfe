"""A job of 10,000 children through the service (issue 42, item 4), on SQLite and PostgreSQL.

What each run stores is bounded (``mgrao_core.budget.stored_weights``: 16 MB of combined weights and 16 MB of
parent-group weights at most, the first children's that fit, and their mean over every child), and what the reads
answer is a page of children, bit for bit the core's, with every limit named in a 422. The Dask path sends back
runs as they are stored (tests/backend/test_dispatcher.py runs such a job on a real cluster).
"""

from __future__ import annotations

import pickle

import numpy as np
from backend_helpers import drain
from fastapi.testclient import TestClient
from large_job import (
    ALGORITHMS,
    CHILDREN,
    EPISODES,
    KEPT_GROUP_CHILDREN,
    PARAMS,
    SEEDS,
    assert_stored_within_bounds,
    core_run,
)

from backend.execution.dask_tasks import simulate_chunk
from backend.execution.worker import Worker
from backend.store.db import Database
from mgrao_core import make_spec
from mgrao_core.budget import MAX_CHUNK_BYTES

BODY = {"system": "multi", "algorithms": ALGORITHMS, "seeds": SEEDS, "episodes": EPISODES, "params": PARAMS}

def test_a_job_of_10000_children_stores_within_its_bounds_and_answers_a_page(
        client: TestClient, worker: Worker, db: Database) -> None:
    job = client.post("/api/jobs", json=BODY | {"name": "10,000 children"}).json()
    assert job.get("id"), job
    drain(worker)
    assert client.get(f"/api/jobs/{job['id']}").json()["status"] == "succeeded"
    assert_stored_within_bounds(db, job["id"])
    bounds = {"combined_values": 2_000_000, "group_values": 2_000_000}

    # one seed: the first 100 children of each configuration, as the core computed them, and the mean over children
    answer = client.get(f"/api/jobs/{job['id']}/weights?seed=1").json()
    assert answer["seed"] == 1 and answer["seeds"] == SEEDS
    by = {c["algorithm"]: c for c in answer["configurations"]}
    mgrao, uniform = core_run("mgrao-100:1", 1), core_run("uniform", 1)
    assert np.array_equal(by["mgrao-100:1"]["combined"], mgrao.combined_weights[:100])
    assert np.array_equal(by["mgrao-100:1"]["groups"], mgrao.group_weights[:100])  # 200,000 values: shown
    assert np.array_equal(by["uniform"]["combined"], uniform.combined_weights[:100]) and by["uniform"]["groups"] == []
    assert by["mgrao-100:1"]["children"] == {"offset": 0, "count": 100, "total": CHILDREN, "combined_stored": CHILDREN,
                                             "groups_stored": KEPT_GROUP_CHILDREN, "bounds": bounds}
    assert by["uniform"]["children"]["groups_stored"] is None
    mean = by["mgrao-100:1"]["mean_over_children"]
    assert np.array_equal(mean["combined"], [mgrao.combined_weights.mean(axis=0)])
    assert np.array_equal(mean["groups"], [mgrao.group_weights.mean(axis=0)])
    assert by["uniform"]["mean_over_children"] == {"combined": [uniform.combined_weights.mean(axis=0).tolist()],
                                                   "groups": []}

    # a page far in: every child's combined weights are stored, the PW of the first 1,000 only, said so
    far = client.get(f"/api/jobs/{job['id']}/weights?seed=1&child_offset=9990&children=50").json()
    learner = next(c for c in far["configurations"] if c["algorithm"] == "mgrao-100:1")
    assert np.array_equal(learner["combined"], mgrao.combined_weights[9990:])  # the last 10: the page ends there
    assert learner["children"]["offset"] == 9990 and learner["children"]["count"] == 10
    assert learner["groups"] is None
    assert "first 1,000 of 10,000 children" in learner["groups_omitted"] and "mean_over_children" in \
        learner["groups_omitted"]
    inside = client.get(f"/api/jobs/{job['id']}/weights?seed=3&child_offset=900&children=100").json()
    learner = next(c for c in inside["configurations"] if c["algorithm"] == "mgrao-100:1")
    assert np.array_equal(learner["groups"], core_run("mgrao-100:1", 3).group_weights[900:1000])
    # a page whose PW exceed what an answer shows: the combined weights, and the PW left out saying how many fit
    wide = client.get(f"/api/jobs/{job['id']}/weights?children=1000").json()
    learner = next(c for c in wide["configurations"] if c["algorithm"] == "mgrao-100:1")
    assert len(learner["combined"]) == 1000 and learner["groups"] is None
    assert "ask for at most 100 children" in learner["groups_omitted"]

    # limits, each named
    for query, field, words in (("child_offset=10000", "child_offset", "must be below n_children = 10,000"),
                                ("children=1001", "children", "1000"),
                                ("children=0", "children", "1"),
                                ("child_offset=-1", "child_offset", "0")):
        refused = client.get(f"/api/jobs/{job['id']}/weights?{query}")
        assert refused.status_code == 422, (query, refused.text)
        detail = refused.json()["detail"][0]
        assert detail["loc"][-1] == field and words in refused.text, (query, refused.text)

    # results: the mean over seeds of the first page, the mean over children, and the answer's size bounded
    results = client.get(f"/api/jobs/{job['id']}/results")
    assert results.status_code == 200
    assert len(results.content) < 6_000_000  # 100 children's weights, not 10,000's (about 40 MB of JSON)
    weights = {c["algorithm"]: c["weights"] for c in results.json()["configurations"]}
    runs = [core_run("mgrao-100:1", seed) for seed in SEEDS]
    assert np.allclose(weights["mgrao-100:1"]["combined"], np.mean([r.combined_weights[:100] for r in runs], axis=0))
    assert np.allclose(weights["mgrao-100:1"]["groups"], np.mean([r.group_weights[:100] for r in runs], axis=0))
    assert weights["mgrao-100:1"]["children"]["count"] == 100
    assert np.allclose(weights["mgrao-100:1"]["mean_over_children"]["groups"],
                       [np.mean([r.group_weights.mean(axis=0) for r in runs], axis=0)])

    # the job list and compare read no weights, and answer as for any job
    listed = client.get("/api/jobs").json()["data"]
    assert listed[0]["id"] == job["id"] and set(listed[0]["summaries"]) == set(ALGORITHMS)
    compared = client.get(f"/api/compare?jobs={job['id']}")
    assert compared.status_code == 200 and {g["algorithm"] for g in compared.json()["groups"]} == set(ALGORITHMS)


def test_the_dask_task_sends_back_runs_as_they_are_stored() -> None:
    # what a Dask worker returns is what the service stores: 17.6 MB for the learner's run, not 161.6 MB
    spec = make_spec("multi", ALGORITHMS, SEEDS, EPISODES, PARAMS)
    rows = simulate_chunk(spec.as_dict(), [1], MAX_CHUNK_BYTES)
    assert [(row["algorithm"], row["seed"]) for row in rows] == [("uniform", 1), ("mgrao-100:1", 1)]
    learner = rows[1]
    assert learner["group_weights"] == core_run("mgrao-100:1", 1).group_weights[:KEPT_GROUP_CHILDREN].tobytes()
    shipped = len(pickle.dumps(rows, protocol=pickle.HIGHEST_PROTOCOL))
    assert shipped < 20_000_000, shipped  # the whole PW would be 160,000,000 bytes
