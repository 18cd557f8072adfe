"""Compare pairs by world, pools only the same computation, and says how many seeds each figure stands on.

Issue 29, points 1-3: each test here failed before the pairing of docs/statistics.md.
"""

from __future__ import annotations

import numpy as np
import pytest
from backend_helpers import JSON, drain
from fastapi.testclient import TestClient
from sqlalchemy import select, update

from backend.execution.worker import Worker
from backend.store.db import Database
from backend.store.models import Run
from mgrao_core import final_utilities, paired_pct_from_uniform

EPISODES = 20


def submit(client: TestClient, **body: object) -> dict:
    answer = client.post("/api/jobs", json={"system": "single", "episodes": EPISODES, **body})
    assert answer.status_code == 202, answer.text
    return answer.json()


def stored(db: Database, job_id: int, algorithm: str) -> dict[int, np.ndarray]:
    with db.session() as session:
        rows = session.execute(select(Run.seed, Run.utilities).where(Run.job_id == job_id,
                                                                     Run.algorithm == algorithm)).all()
    return {seed: np.frombuffer(blob, dtype="<f8").copy() for seed, blob in rows}


def log_external(client: TestClient, label: str, runs: dict[int, np.ndarray], **body: object) -> int:
    opened = client.post("/api/external-runs", json={"label": label, "system": "single", "episodes": EPISODES,
                                                     "seeds": sorted(runs), **body})
    assert opened.status_code in (200, 201), opened.text
    run_id = opened.json()["job"]["id"]
    pieces = [{"seed": seed, "start": 0, "values": values.tolist()} for seed, values in runs.items()]
    sent = client.post(f"/api/external-runs/{run_id}/batches", json={"key": "all", "utilities": pieces})
    assert sent.status_code == 200, sent.text
    closed = client.post(f"/api/external-runs/{run_id}/close", headers=JSON)
    assert closed.status_code == 200, closed.text
    return run_id


def final(values: np.ndarray) -> float:
    return float(final_utilities(values)[0])


def groups_of(client: TestClient, ids: list[int]) -> dict[str, dict]:
    answer = client.get(f"/api/compare?jobs={','.join(map(str, ids))}")
    assert answer.status_code == 200, answer.text
    return {g["label"]: g for g in answer.json()["groups"]}


def test_partly_shared_seeds_are_paired_on_the_seeds_shared_and_say_how_many(
        client: TestClient, worker: Worker, db: Database) -> None:
    built_in = submit(client, seeds=20, algorithms=["uniform", "mgrao-max"])
    assert drain(worker) == 1
    uniform = stored(db, built_in["id"], "uniform")
    most = stored(db, built_in["id"], "mgrao-max")
    # a learner logged on seeds 10-29: 10 of them shared with the built-in job
    mine = {seed: (uniform[seed] if seed in uniform else uniform[seed - 10]) * 1.1 for seed in range(10, 30)}
    run_id = log_external(client, "mine", mine)
    groups = groups_of(client, [built_in["id"], run_id])
    summary = groups["mine"]["summary"]
    assert summary["n_runs"] == 20 and summary["n_paired"] == 10 and summary["partial"] is True
    pct = paired_pct_from_uniform({s: final(v) for s, v in mine.items()}, {s: final(v) for s, v in uniform.items()})
    assert sorted(pct) == list(range(10, 20))
    assert summary["pct_from_uniform"] == pytest.approx(np.mean(list(pct.values())), rel=1e-12)
    # % of max: both gains over the seeds all three share (10-19), not mgrao-max's over its own 0-19
    max_pct = paired_pct_from_uniform({s: final(v) for s, v in most.items()}, {s: final(v) for s, v in uniform.items()})
    shared = range(10, 20)
    expected = 100 * np.mean([pct[s] for s in shared]) / np.mean([max_pct[s] for s in shared])
    assert summary["n_paired_max"] == 10
    assert summary["pct_of_max"] == pytest.approx(expected, rel=1e-12)
    assert groups["mgrao-max"]["summary"]["n_paired"] == 20 and groups["mgrao-max"]["summary"]["partial"] is False


def test_same_label_runs_pool_only_when_they_are_the_same_computation(
        client: TestClient, worker: Worker, db: Database) -> None:
    built_in = submit(client, seeds=6, algorithms=["uniform"])
    assert drain(worker) == 1
    uniform = stored(db, built_in["id"], "uniform")
    first = log_external(client, "hedge", {s: uniform[s] * 1.2 for s in range(0, 3)})
    parts = log_external(client, "hedge", {s: uniform[s] * 1.2 for s in range(3, 6)})  # the same learner, more seeds
    tuned = log_external(client, "hedge", {s: uniform[s] * 1.5 for s in range(0, 6)}, params={"learning_rate": 0.3})
    other = log_external(client, "hedge", {s: uniform[s] * 0.9 for s in range(0, 3)})  # same settings, other numbers
    groups = groups_of(client, [built_in["id"], first, parts, tuned])
    hedges = {label: g for label, g in groups.items() if g["algorithm"] == "hedge"}
    assert set(hedges) == {"hedge (learning_rate=0.1)", "hedge (learning_rate=0.3)"}
    pooled = hedges["hedge (learning_rate=0.1)"]  # logged in two parts over different seeds: one configuration
    assert pooled["job_ids"] == [first, parts] and pooled["summary"]["n_runs"] == 6
    assert pooled["summary"]["pct_from_uniform"] == pytest.approx(20.0, rel=1e-9)
    assert hedges["hedge (learning_rate=0.3)"]["summary"]["pct_from_uniform"] == pytest.approx(50.0, rel=1e-9)
    # the same settings with other numbers on seeds 0-2: apart, whichever comes first in ?jobs=; parts shares no
    # seed with either of the two and cannot be told to belong to one: apart too
    groups = groups_of(client, [built_in["id"], other, first, parts, tuned])
    hedges = {label: g for label, g in groups.items() if g["algorithm"] == "hedge"}
    assert set(hedges) == {f"hedge (learning_rate=0.1; job {other})", f"hedge (learning_rate=0.1; job {first})",
                           f"hedge (learning_rate=0.1; job {parts})", "hedge (learning_rate=0.3)"}
    assert hedges[f"hedge (learning_rate=0.1; job {other})"]["summary"]["pct_from_uniform"] == pytest.approx(-10.0)
    assert hedges[f"hedge (learning_rate=0.1; job {first})"]["summary"]["pct_from_uniform"] == pytest.approx(20.0)
    assert all(g["mismatched_seeds"] == [] for g in groups.values())


def test_built_in_runs_of_one_configuration_pool_and_a_seed_that_differs_is_flagged(
        client: TestClient, worker: Worker, db: Database) -> None:
    one = submit(client, seeds=4, algorithms=["uniform", "mgrao-1:1"])
    two = submit(client, seeds=[2, 3, 4, 5], algorithms=["uniform", "mgrao-1:1"])
    assert drain(worker) == 2
    groups = groups_of(client, [two["id"], one["id"]])
    assert set(groups) == {"uniform", "mgrao-1:1"}
    assert groups["mgrao-1:1"]["summary"]["n_runs"] == 6 and groups["mgrao-1:1"]["mismatched_seeds"] == []
    with db.session() as session, session.begin():  # as if the second job ran on another engine: seed 3 differs
        blob = np.frombuffer(session.scalar(select(Run.utilities).where(
            Run.job_id == two["id"], Run.algorithm == "mgrao-1:1", Run.seed == 3)), dtype="<f8") + 1.0
        session.execute(update(Run).where(Run.job_id == two["id"], Run.algorithm == "mgrao-1:1", Run.seed == 3)
                        .values(utilities=blob.astype("<f8").tobytes()))
    groups = groups_of(client, [one["id"], two["id"]])
    assert groups["mgrao-1:1"]["mismatched_seeds"] == [3] and groups["uniform"]["mismatched_seeds"] == []
    kept = stored(db, one["id"], "mgrao-1:1")[3]  # the first job's run is the one used
    assert groups["mgrao-1:1"]["summary"]["n_runs"] == 6
    finals = {s: final(v) for s, v in stored(db, one["id"], "mgrao-1:1").items()}
    finals |= {s: final(v) for s, v in stored(db, two["id"], "mgrao-1:1").items() if s not in finals}
    assert finals[3] == final(kept)
    assert groups["mgrao-1:1"]["summary"]["final_mean"] == pytest.approx(np.mean(list(finals.values())), rel=1e-12)


def test_a_learners_own_parameters_do_not_change_its_world(client: TestClient, worker: Worker, db: Database) -> None:
    base = submit(client, seeds=5, algorithms=["uniform", "mgrao-1:1"])
    faster = submit(client, seeds=5, algorithms=["mgrao-1:1"], params={"learning_rate": 0.3})
    assert drain(worker) == 2
    assert base["config_hash"] != faster["config_hash"]
    uniform = stored(db, base["id"], "uniform")
    logged = log_external(client, "mine", {s: uniform[s] * 1.1 for s in range(5)}, params={"learning_rate": 0.2})
    groups = groups_of(client, [base["id"], faster["id"], logged])
    assert set(groups) == {"uniform", "mgrao-1:1 (learning_rate=0.1)", "mgrao-1:1 (learning_rate=0.3)", "mine"}
    assert {g["world"] for g in groups.values()} == {"single"}
    fast = groups["mgrao-1:1 (learning_rate=0.3)"]["summary"]
    assert fast["n_paired"] == 5 and fast["pct_from_uniform"] is not None
    pct = paired_pct_from_uniform({s: final(v) for s, v in stored(db, faster["id"], "mgrao-1:1").items()},
                                  {s: final(v) for s, v in uniform.items()})
    assert fast["pct_from_uniform"] == pytest.approx(np.mean(list(pct.values())), rel=1e-12)
    assert groups["mine"]["summary"]["pct_from_uniform"] == pytest.approx(10.0, rel=1e-9)
    assert groups["mine"]["params"]["learning_rate"] == 0.2


def test_worlds_that_share_a_system_are_named_by_what_differs(client: TestClient, worker: Worker) -> None:
    short = submit(client, seeds=3, algorithms=["uniform", "mgrao-max"])
    longer = submit(client, seeds=3, algorithms=["uniform", "mgrao-max"], episodes=30)
    assert drain(worker) == 2
    answer = client.get(f"/api/compare?jobs={short['id']},{longer['id']}").json()
    assert {g["world"] for g in answer["groups"]} == {"single (episodes=20)", "single (episodes=30)"}
    assert all(g["summary"]["n_paired"] == 3 for g in answer["groups"])


def test_other_parameters_on_another_system_are_another_configuration(client: TestClient, worker: Worker) -> None:
    single = submit(client, seeds=3, algorithms=["uniform", "mgrao-1:1"])
    large = submit(client, system="large", seeds=3, algorithms=["uniform", "mgrao-1:1"], params={"learning_rate": 0.5})
    assert drain(worker) == 2
    groups = client.get(f"/api/compare?jobs={single['id']},{large['id']}").json()["groups"]
    assert {(g["world"], g["label"]) for g in groups} == {
        ("single", "uniform"), ("single", "mgrao-1:1 (learning_rate=0.1)"),
        ("large", "uniform"), ("large", "mgrao-1:1 (learning_rate=0.5)")}  # never aggregated as one


def test_a_run_whose_final_is_not_finite_is_left_out_and_named(client: TestClient, worker: Worker,
                                                              db: Database) -> None:
    job = submit(client, seeds=4, algorithms=["uniform", "mgrao-max"])
    assert drain(worker) == 1
    with db.session() as session, session.begin():  # a corrupted store: one run's episodes are NaN
        session.execute(update(Run).where(Run.job_id == job["id"], Run.algorithm == "mgrao-max", Run.seed == 2)
                        .values(utilities=np.full(EPISODES, np.nan).astype("<f8").tobytes()))
    groups = groups_of(client, [job["id"]])
    assert groups["mgrao-max"]["non_finite_seeds"] == [2]
    summary = groups["mgrao-max"]["summary"]
    assert summary["n_runs"] == 3 and summary["n_paired"] == 3 and summary["pct_from_uniform"] is not None
    statistics = client.get(f"/api/compare/statistics?jobs={job['id']}&reps=50").json()
    assert next(c for c in statistics["configurations"] if c["label"] == "mgrao-max")["non_finite_seeds"] == [2]
