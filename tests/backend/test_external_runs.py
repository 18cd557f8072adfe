"""Runs logged from outside (``/api/external-runs``): storage, idempotency, validation, pairing with built-in runs.

Every test runs on a real SQLite file and on the real PostgreSQL server (``db_url``), and asserts the
very same answers on both.
"""

from __future__ import annotations

import numpy as np
import pytest
from backend_helpers import JSON, drain
from fastapi.testclient import TestClient
from sqlalchemy import func, select

from backend.execution.worker import Worker
from backend.store import queue
from backend.store.db import Database
from backend.store.models import ExternalBatch, ExternalPiece, Run
from mgrao_core import final_utilities, paired_pct_from_uniform


def open_run(client: TestClient, **body: object) -> dict:
    answer = client.post("/api/external-runs", json={"label": "my-learner", "system": "single", "seeds": 2,
                                                     "episodes": 5, **body})
    assert answer.status_code in (200, 201), answer.text
    return answer.json()


def batch(client: TestClient, run_id: int, key: str, utilities=(), weights=()) -> tuple[int, dict]:
    answer = client.post(f"/api/external-runs/{run_id}/batches",
                         json={"key": key, "utilities": list(utilities), "weights": list(weights)})
    return answer.status_code, answer.json()


def close(client: TestClient, run_id: int) -> tuple[int, dict]:
    answer = client.post(f"/api/external-runs/{run_id}/close", headers=JSON)
    return answer.status_code, answer.json()


def runs_of(db: Database, job_id: int) -> dict[int, np.ndarray]:
    with db.session() as session:
        rows = session.execute(select(Run.seed, Run.utilities).where(Run.job_id == job_id)).all()
    return {seed: np.frombuffer(blob, dtype="<f8") for seed, blob in rows}


def test_an_external_run_is_a_job_of_kind_external_in_the_world_of_its_system(client: TestClient) -> None:
    run = open_run(client, params={"n_types": 10}, seeds=[3, 7], name="outside", tags=["ext"])
    job = run["job"]
    assert (job["kind"], job["status"], job["algorithms"], job["seeds"]) == ("external", "open", ["my-learner"], [3, 7])
    assert run["seeds"] == [{"seed": 3, "episodes_stored": 0, "complete": False, "weights": False},
                            {"seed": 7, "episodes_stored": 0, "complete": False, "weights": False}]
    assert run["limits"]["weights_shape"] == [1, 10]
    built_in = client.post("/api/jobs", json={"system": "single", "seeds": 2, "episodes": 5,
                                              "params": {"n_types": "10"}})
    assert built_in.json()["config_hash"] == job["config_hash"]
    assert built_in.json()["kind"] == "simulation"
    assert client.get(f"/api/jobs/{job['id']}").json()["kind"] == "external"
    listed = {j["id"]: j["kind"] for j in client.get("/api/jobs").json()["data"]}
    assert listed == {job["id"]: "external", built_in.json()["id"]: "simulation"}
    assert [j["id"] for j in client.get("/api/jobs?kind=external").json()["data"]] == [job["id"]]
    assert [j["id"] for j in client.get("/api/jobs?status=open").json()["data"]] == [job["id"]]


def test_workers_never_claim_an_external_run(client: TestClient, worker: Worker, db: Database) -> None:
    open_run(client)
    with db.session() as session:
        assert not queue.has_work(session, stale_after_s=2)
    assert worker.run_once() == 0  # nothing claimed


def test_a_batch_sent_again_stores_nothing_twice(client: TestClient, db: Database) -> None:
    run_id = open_run(client)["job"]["id"]
    pieces = [{"seed": 0, "values": [1.0, 2.0, 3.0]}, {"seed": 1, "values": [1, 2, 3, 4, 5]}]
    status, first = batch(client, run_id, "k1", pieces)
    assert (status, first) == (200, {"replayed": False, "values": 8, "status": "open", "progress": 0.8,
                                     "seeds_complete": 1, "values_stored": 8})
    status, again = batch(client, run_id, "k1", pieces)
    assert (status, again["replayed"], again["values"], again["values_stored"]) == (200, True, 8, 8)
    # the same key with other content is refused; an identical piece under a new key is skipped
    status, other = batch(client, run_id, "k1", [{"seed": 0, "start": 3, "values": [4.0, 5.0]}])
    assert status == 409 and "batch key 'k1' was already used" in other["detail"]
    status, same = batch(client, run_id, "k2", pieces)
    assert (status, same["replayed"], same["values"], same["values_stored"]) == (200, False, 0, 8)
    status, overlap = batch(client, run_id, "k3", [{"seed": 0, "start": 2, "values": [9.0, 4.0]}])
    assert (status, overlap["detail"]) == (409, "utilities[0]: episodes 2-3 of seed 0 overlap episodes 0-2, already "
                                                 "stored with other values (a batch's episodes may be sent again "
                                                 "only as they were)")
    status, changed = batch(client, run_id, "k4", [{"seed": 1, "start": 4, "values": [6.0]}])
    assert (status, changed["detail"]) == (409, "utilities[0]: episode 4 of seed 1 differ from the values already "
                                                "stored (seed 1 is complete)")
    assert batch(client, run_id, "k5", [{"seed": 0, "start": 3, "values": [4.0, 5.0]}])[0] == 200
    stored = runs_of(db, run_id)
    assert {s: v.tolist() for s, v in stored.items()} == {0: [1, 2, 3, 4, 5], 1: [1, 2, 3, 4, 5]}
    with db.session() as session:
        assert session.scalar(select(func.count()).select_from(ExternalPiece)) == 0
        assert session.scalar(select(func.count()).select_from(ExternalBatch)) == 3  # k1, k2, k5


def test_closing_checks_every_seed_and_the_weights(client: TestClient) -> None:
    run_id = open_run(client)["job"]["id"]
    batch(client, run_id, "a", [{"seed": 0, "values": [1, 2, 3, 4, 5]}, {"seed": 1, "values": [1, 2]}])
    status, answer = close(client, run_id)
    assert (status, answer["detail"]) == (409, f"external run {run_id} is incomplete: 1 of its 2 seeds lack "
                                               "episodes: seed 1 (2 of 5 episodes)")
    status, answer = batch(client, run_id, "b", weights=[{"seed": 1, "weights": [[0.05] * 20]}])
    assert (status, answer["detail"]) == (409, "weights[0]: seed 1 has 2 of its 5 episodes stored: send a seed's "
                                               "final weights once every episode of it is stored (in the same batch "
                                               "or later)")
    status, answer = batch(client, run_id, "c", [{"seed": 1, "start": 2, "values": [3, 4, 5]}],
                           weights=[{"seed": 1, "weights": [[0.05] * 20]}])
    assert status == 200 and answer["seeds_complete"] == 2
    status, answer = close(client, run_id)
    assert (status, answer["detail"]) == (409, f"external run {run_id} has final weights for 1 seeds but not for 1 "
                                               "(seeds 0): send every seed's weights or none")
    assert batch(client, run_id, "d", weights=[{"seed": 0, "weights": [[1.0] + [0.0] * 19]}])[0] == 200
    status, answer = close(client, run_id)
    assert status == 200 and answer["status"] == "succeeded" and answer["job"]["status"] == "succeeded"
    assert close(client, run_id) == (status, answer)  # closing again: the same answer
    assert batch(client, run_id, "d", weights=[{"seed": 0, "weights": [[1.0] + [0.0] * 19]}])[1]["replayed"]
    status, answer = batch(client, run_id, "e", [{"seed": 0, "values": [1.0]}])
    assert (status, answer["detail"]) == (409, f"external run {run_id} is succeeded: it takes no more batches")
    weights = client.get(f"/api/jobs/{run_id}/weights?seed=0").json()["configurations"][0]
    assert weights["combined"] == [[1.0] + [0.0] * 19]
    results = client.get(f"/api/jobs/{run_id}/results").json()
    assert results["partial"] is False and results["configurations"][0]["weights"]["combined"][0][0] == 0.525
    listed = client.get("/api/jobs").json()["data"][0]
    final = float(final_utilities(np.array([1.0, 2, 3, 4, 5]))[0])
    assert listed["summaries"]["my-learner"]["final_mean"] == final


def test_an_open_run_shows_its_complete_seeds_and_can_be_deleted(client: TestClient, db: Database) -> None:
    run_id = open_run(client)["job"]["id"]
    batch(client, run_id, "a", [{"seed": 0, "values": [1, 2, 3, 4, 5]}, {"seed": 1, "values": [1, 2]}])
    results = client.get(f"/api/jobs/{run_id}/results")
    assert results.status_code == 200 and results.json()["partial"] is True
    assert results.json()["configurations"][0]["seeds_done"] == 1
    assert client.get(f"/api/jobs/{run_id}/weights").json()["configurations"][0]["combined"] == [[]]
    state = client.get(f"/api/external-runs/{run_id}").json()
    assert [s["episodes_stored"] for s in state["seeds"]] == [5, 2] and state["progress"] == 0.7
    assert client.delete(f"/api/jobs/{run_id}", headers=JSON).status_code == 204
    with db.session() as session:
        assert session.scalar(select(func.count()).select_from(ExternalPiece)) == 0
    assert client.get(f"/api/external-runs/{run_id}").status_code == 404


def test_an_open_key_answers_the_same_run(client: TestClient) -> None:
    first = open_run(client, key="resume-1")
    again = client.post("/api/external-runs", json={"label": "my-learner", "system": "single", "seeds": 2,
                                                    "episodes": 5, "key": "resume-1", "name": "another name"})
    assert again.status_code == 200 and again.json()["job"]["id"] == first["job"]["id"]
    other = client.post("/api/external-runs", json={"label": "my-learner", "system": "single", "seeds": 3,
                                                    "episodes": 5, "key": "resume-1"})
    assert other.status_code == 409
    assert other.json()["detail"] == (f"key 'resume-1' already opened external run {first['job']['id']} with another "
                                      "label, system, parameters, seeds or episodes: use another key")


def test_a_simulated_job_is_no_external_run(client: TestClient) -> None:
    job = client.post("/api/jobs", json={"system": "single", "seeds": 1, "episodes": 5}).json()
    answer = client.get(f"/api/external-runs/{job['id']}")
    assert (answer.status_code, answer.json()["detail"]) == (
        404, f"external run {job['id']} not found: job {job['id']} is a simulation job")
    assert batch(client, job["id"], "a", [{"seed": 0, "values": [1.0]}])[0] == 404
    assert close(client, 999)[0] == 404


REFUSED_OPENINGS = [
    ({"label": "uniform"}, "label", "label: 'uniform' is the built-in algorithm 'uniform' (GET /api/algorithms): an "
                                    "external run needs a label of its own, e.g. 'my-learner'"),
    ({"label": "mgrao-05:1"}, "label", None),  # not the pattern (':')
    ({"label": "mgrao-max"}, "label", "label: 'mgrao-max' is the built-in algorithm 'mgrao-max' (GET /api/algorithms): "
                                      "an external run needs a label of its own, e.g. 'my-learner'"),
    ({"label": "oracle"}, "label", None),
    ({"label": "My-Learner"}, "label", None),
    ({"label": "x" * 33}, "label", None),
    ({"system": "nope"}, "system",
     "system: unknown system 'nope': use one of single, multi, volatile, large, drift, bursty, "
     "multi-resource, cloud, edge"),
    ({"params": {"n_types": 1}}, "n_types", "n_types: must be in [2, 200] (got 1)"),
    ({"params": {"nope": 1}}, "nope", None),
    ({"seeds": [4, 5, 4]}, "seeds[2]", "seeds[2]: repeats seeds[0] (4): a run's seeds are distinct"),
    ({"seeds": 1001}, "seeds", None),
    ({"episodes": 0}, "episodes", None),
    ({"episodes": 100_001}, "episodes", None),
    ({"key": "no spaces"}, "key", None),
    ({"label": "ok", "extra": 1}, "extra", None),
]


@pytest.mark.parametrize(("change", "field", "message"), REFUSED_OPENINGS)
def test_an_opening_is_refused_naming_the_field(client: TestClient, change: dict, field: str,
                                                message: str | None) -> None:
    body = {"label": "my-learner", "system": "single", "seeds": 2, "episodes": 5} | change
    answer = client.post("/api/external-runs", json=body)
    assert answer.status_code == 422, answer.text
    (detail,) = answer.json()["detail"]
    assert detail["field"] == field
    if message is not None:
        assert detail["msg"] == message
    assert client.get("/api/jobs").json()["count"] == 0


REFUSED_BATCHES = [
    ({"utilities": [{"seed": 9, "values": [1.0]}]}, "utilities[0]",
     "utilities[0]: seed 9 is not one of the run's 2 seeds (0, 1)"),
    ({"utilities": [{"seed": 0, "start": 4, "values": [1.0, 2.0]}]}, "utilities[0]",
     "utilities[0]: episodes 4-5 go past the run's 5 episodes (episodes are counted from 0: the last is 4)"),
    ({"utilities": [{"seed": 0, "values": [1.0, 2.0]}, {"seed": 0, "start": 1, "values": [3.0]}]}, "utilities[1]",
     "utilities[1]: episodes 1-1 of seed 0 overlap utilities[0] of the same batch"),
    ({"utilities": [{"seed": 0, "values": []}]}, "utilities[0].values", None),
    ({"utilities": [{"seed": 0, "values": ["x"]}]}, "utilities[0].values[0]", None),
    ({"utilities": [{"seed": 0, "values": [False]}]}, "utilities[0].values[0]",  # a number, not what JSON's false
     "utilities[0].values[0]: must be a number (got false)"),                    # could be read as (Schemathesis)
    ({"weights": [{"seed": 0, "weights": [[0.1] * 19]}]}, "weights[0]",
     "weights[0]: must be 1 rows (one per child) of 20 values (one per type), got 1 rows of [19] values"),
    ({"weights": [{"seed": 0, "weights": [[-0.1] * 20]}]}, "weights[0].weights[0][0]", None),
    ({"weights": [{"seed": {}, "weights": [[0.05] * 20]}]}, "weights[0].seed", "weights[0].seed: must be a whole "
                                                                             "number (got dict)"),
    ({"weights": [{"seed": 0, "weights": [[0.05] * 20]}, {"seed": 0, "weights": [[0.05] * 20]}]}, "weights[1]",
     "weights[1]: repeats weights[0] (seed 0)"),
    ({"key": ""}, "key", None),
    ({"key": "k" * 65}, "key", None),
]


@pytest.mark.parametrize(("change", "field", "message"), REFUSED_BATCHES)
def test_a_batch_is_refused_naming_the_field_and_stores_nothing(client: TestClient, db: Database, change: dict,
                                                                field: str, message: str | None) -> None:
    run_id = open_run(client)["job"]["id"]
    answer = client.post(f"/api/external-runs/{run_id}/batches", json={"key": "k"} | change)
    assert answer.status_code == 422, answer.text
    (detail,) = answer.json()["detail"]
    assert detail["field"] == field
    if message is not None:
        assert detail["msg"] == message
    with db.session() as session:
        assert session.scalar(select(func.count()).select_from(ExternalBatch)) == 0


@pytest.mark.parametrize("number", ["NaN", "Infinity", "-Infinity", "1e400"])
def test_values_that_are_not_finite_are_refused(client: TestClient, number: str) -> None:
    run_id = open_run(client)["job"]["id"]
    answer = client.post(f"/api/external-runs/{run_id}/batches", headers=JSON,
                         content=f'{{"key": "k", "utilities": [{{"seed": 0, "values": [1.0, {number}]}}]}}')
    assert answer.status_code == 422, answer.text
    assert answer.json()["detail"][0]["field"] == "utilities[0].values[1]"
    assert "finite" in answer.json()["detail"][0]["msg"]


def test_a_batch_over_the_body_limit_is_refused(client: TestClient) -> None:
    run_id = open_run(client, episodes=100_000, seeds=1)["job"]["id"]
    answer = client.post(f"/api/external-runs/{run_id}/batches",
                         json={"key": "k", "utilities": [{"seed": 0, "values": [0.123456789] * 20_000}]})
    assert answer.status_code == 413


def test_compare_pairs_an_external_run_seed_by_seed_with_built_in_runs_of_its_world(
        client: TestClient, worker: Worker, db: Database) -> None:
    built_in = client.post("/api/jobs", json={"system": "single", "seeds": 3, "episodes": 20,
                                              "algorithms": ["uniform", "mgrao-max"]}).json()
    assert drain(worker) == 1
    uniform = {seed: values for seed, values in runs_of(db, built_in["id"]).items()}
    with db.session() as session:
        uniform = {seed: np.frombuffer(blob, dtype="<f8") for seed, blob in session.execute(
            select(Run.seed, Run.utilities).where(Run.job_id == built_in["id"], Run.algorithm == "uniform"))}
    run = open_run(client, seeds=[2, 0, 1], episodes=20)
    run_id = run["job"]["id"]
    assert run["job"]["config_hash"] == built_in["config_hash"]
    mine = {seed: uniform[seed] * (1.0 + 0.1 * (seed + 1)) for seed in uniform}  # 10%, 20%, 30% above uniform
    status, _ = batch(client, run_id, "all", [{"seed": s, "values": v.tolist()} for s, v in mine.items()])
    assert status == 200 and close(client, run_id)[0] == 200
    compare = client.get(f"/api/compare?jobs={built_in['id']},{run_id}").json()
    groups = {g["algorithm"]: g for g in compare["groups"]}
    assert list(groups) == ["uniform", "mgrao-max", "my-learner"]
    assert {g["config_hash"] for g in groups.values()} == {built_in["config_hash"]}
    assert groups["my-learner"]["job_ids"] == [run_id]
    finals = {s: float(final_utilities(v)[0]) for s, v in mine.items()}
    base = {s: float(final_utilities(v)[0]) for s, v in uniform.items()}
    expected = np.mean(list(paired_pct_from_uniform(finals, base).values()))
    assert groups["my-learner"]["summary"]["pct_from_uniform"] == pytest.approx(expected, rel=1e-12)
    assert groups["my-learner"]["summary"]["pct_from_uniform"] == pytest.approx(20.0, rel=1e-9)
    assert [j["kind"] for j in compare["jobs"]] == ["simulation", "external"]


def test_a_batch_moves_the_jobs_change_token(client: TestClient) -> None:
    run_id = open_run(client)["job"]["id"]
    token = client.get("/api/jobs/changes").json()["token"]
    batch(client, run_id, "a", [{"seed": 0, "values": [1.0]}])
    assert client.get(f"/api/jobs/changes?since={token}").json()["changed"] is True
