"""``mgrao-x:y`` (issue 45) through the service: a job runs it, compare pairs it with ``mgrao-x:1``'s world and its
statistics count it as any configuration, in the registry's order."""

from __future__ import annotations

import numpy as np
import pytest
from backend_helpers import drain
from fastapi.testclient import TestClient
from sqlalchemy import select

from backend.execution.worker import Worker
from backend.store.db import Database
from backend.store.models import Run
from mgrao_core import final_utilities, make_spec, run_experiment

SEEDS, EPISODES = 6, 12


def submit(client: TestClient, algorithms: list[str]) -> int:
    answer = client.post("/api/jobs", json={"system": "multi", "seeds": SEEDS, "episodes": EPISODES,
                                            "algorithms": algorithms})
    assert answer.status_code == 202, answer.text
    return answer.json()["id"]


def test_a_shared_configuration_is_stored_compared_and_counted(client: TestClient, worker: Worker,
                                                               db: Database) -> None:
    own = submit(client, ["uniform", "mgrao-5:1", "mgrao-max", "oracle"])
    shared = submit(client, ["uniform", "mgrao-05:03"])
    assert drain(worker) == 2
    expected = run_experiment(make_spec("multi", ["uniform", "mgrao-5:3"], seeds=SEEDS, episodes=EPISODES))
    with db.session() as session:
        rows = dict(session.execute(select(Run.seed, Run.utilities).where(Run.job_id == shared,
                                                                          Run.algorithm == "mgrao-5:3")).all())
    for run in (r for r in expected.runs if r.algorithm == "mgrao-5:3"):  # the core's numbers, stored
        assert np.array_equal(np.frombuffer(rows[run.seed], dtype="<f8"), run.utilities)
    answer = client.get(f"/api/compare?jobs={own},{shared}")
    assert answer.status_code == 200, answer.text
    groups = {g["label"]: g for g in answer.json()["groups"]}
    summary = groups["mgrao-5:3"]["summary"]
    assert summary["n_paired"] == SEEDS and summary["partial"] is False  # paired with the other job's uniform
    pct = 100 * np.mean(final_utilities(expected.utilities("mgrao-5:3"))
                        / final_utilities(expected.utilities("uniform")) - 1)
    assert summary["pct_from_uniform"] == pytest.approx(pct, rel=1e-9)
    statistics = client.get(f"/api/compare/statistics?jobs={own},{shared}&reps=200&seed=1")
    assert statistics.status_code == 200, statistics.text
    body = statistics.json()
    assert "mgrao-5:3" in body["systems"]["multi"]
    labels = [c["label"] for c in body["configurations"]]
    assert labels.index("mgrao-5:1") < labels.index("mgrao-5:3") < labels.index("mgrao-max")
