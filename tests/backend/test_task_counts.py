"""Tasks that fail and hierarchical allocation through the service: each stored run keeps its task counts, and
every configuration's summary the API serves carries its failure and hand-over rates, pooled over its seeds.

A real database (SQLite and PostgreSQL), real workers driven in-process: one that runs the job alone (its runs
stored chunk by chunk, the summary read back from them) and one that runs it in a batch of small jobs (stored
and summarised in one transaction from the rows).
"""

from __future__ import annotations

from fastapi.testclient import TestClient
from sqlalchemy import select

from backend.execution.worker import Worker
from backend.processes import local_worker
from backend.settings import Settings
from backend.store.db import Database
from backend.store.models import Run
from mgrao_core import TaskCounts, make_spec, run_experiment
from tests.backend.backend_helpers import drain

ALGORITHMS = ["uniform", "mgrao-1:1"]
FAILING = {"task_need": 1.5, "hierarchy": "hand-over"}
BODY = {"system": "multi", "algorithms": ALGORITHMS, "seeds": 2, "episodes": 20, "params": FAILING}


def test_a_job_whose_tasks_fail_stores_its_counts_and_answers_the_cores_rates(
        client: TestClient, worker: Worker, settings: Settings, db: Database) -> None:
    expected = run_experiment(make_spec("multi", ALGORITHMS, seeds=2, episodes=20, overrides=FAILING))
    rates = {a: counts.rates() for a, counts in expected.task_counts().items()}
    assert all(0 < r["failure_rate"] < 1 and 0 < r["handover_rate"] < 1 for r in rates.values()), rates

    alone = client.post("/api/jobs", json=BODY | {"name": "alone"}).json()
    one_by_one = local_worker(settings.model_copy(update={"small_job_work": 0}), worker_id="alone-worker")
    try:
        assert drain(one_by_one) == 1  # not small: stored chunk by chunk, summarised from the stored runs
    finally:
        one_by_one.db.dispose()
    batched = client.post("/api/jobs", json=BODY | {"name": "batched"}).json()
    assert drain(worker) == 1  # small: stored and summarised from its rows in the batch's transaction
    assert alone["config_hash"] == batched["config_hash"]

    with db.session() as session:
        stored = {(r.job_id, r.algorithm, r.seed): TaskCounts(r.tasks_allocated, r.tasks_failed, r.tasks_handed_over)
                  for r in session.scalars(select(Run))}
    assert stored == {(job["id"], run.algorithm, run.seed): run.tasks for job in (alone, batched)
                      for run in expected.runs}

    listed = {job["id"]: job for job in client.get("/api/jobs").json()["data"]}
    for job in (alone, batched):
        read = client.get(f"/api/jobs/{job['id']}").json()
        assert read["status"] == "succeeded", read["error"]
        results = client.get(f"/api/jobs/{job['id']}/results").json()["configurations"]
        for algorithm in ALGORITHMS:
            for where, summary in (("job", read["summaries"][algorithm]), ("list", listed[job["id"]]["summaries"][
                    algorithm]), ("results", next(c["summary"] for c in results if c["algorithm"] == algorithm))):
                got = {k: summary[k] for k in ("failure_rate", "handover_rate")}
                assert got == rates[algorithm], (where, job["name"], algorithm)

    # compare pools the two jobs' runs (the same configuration): each seed's counts once, not twice
    compared = client.get(f"/api/compare?jobs={alone['id']},{batched['id']}").json()["groups"]
    assert {g["algorithm"]: {k: g["summary"][k] for k in rates["uniform"]} for g in compared} == rates
    statistics = client.get(f"/api/compare/statistics?jobs={alone['id']}&reps=10").json()["systems"]["multi"]
    assert {a: {k: s[k] for k in rates["uniform"]} for a, s in statistics.items()} == rates
