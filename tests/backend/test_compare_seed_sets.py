"""Comparisons of stored jobs that ran other seeds, and of one system in several worlds (issue 47, items 1-2).

On SQLite and PostgreSQL: every system's scores stand on its anchor seeds (uniform's mean score is 0 and the
oracle's 1 on every system, whatever seeds each job ran, a job stopped by a rule among them); a system with
several worlds among the jobs is aggregated once, in the world the user picks (``aggregate=``), or not at all.
"""

from __future__ import annotations

import numpy as np
import pytest
from backend_helpers import drain
from fastapi.testclient import TestClient

from backend.execution.worker import Worker


def _submit(client: TestClient, body: dict) -> int:
    answer = client.post("/api/jobs", json=body)
    assert answer.status_code == 202, answer.text
    return answer.json()["id"]


def test_every_system_scores_on_its_anchor_seeds_with_rule_stopped_jobs(client: TestClient, worker: Worker) -> None:
    single = _submit(client, {"system": "single", "seeds": list(range(20)), "episodes": 20,
                              "algorithms": ["uniform", "mgrao-1:1", "oracle"]})
    stopped = _submit(client, {"system": "single", "first_seed": 0, "episodes": 20,
                               "algorithms": ["uniform", "mgrao-max"],
                               "until": {"half_width": 1000, "max_seeds": 30, "block": 10}})
    multi = _submit(client, {"system": "multi", "seeds": list(range(6)), "episodes": 20,
                             "algorithms": ["uniform", "mgrao-1:1", "mgrao-max", "oracle"]})
    assert drain(worker) == 3
    assert client.get(f"/api/jobs/{stopped}").json()["stopped"]["seeds"] == 10  # stopped at its first look
    answer = client.get(f"/api/compare/statistics?jobs={single},{stopped},{multi}&reps=200")
    assert answer.status_code == 200, answer.text
    body = answer.json()
    aggregated = body["aggregated"]
    assert aggregated["systems"] == ["single", "multi"] and aggregated["n_seeds"] == {"single": 20, "multi": 6}
    assert aggregated["runs"]["mgrao-max"] == {"single": 10, "multi": 6}  # the rule's 10 seeds, all kept
    for label, expected in (("uniform", 0.0), ("oracle", 1.0)):
        for system in ("single", "multi"):
            assert np.mean(body["scores"][label][system]) == pytest.approx(expected, abs=1e-9)
        for metric in ("mean", "median"):
            assert body["aggregate"][label][metric]["estimate"] == pytest.approx(expected, abs=1e-9)
    assert aggregated["left_out"] == {}
    assert "each system weighs the same" in aggregated["weighting"]
    table = client.get(f"/api/compare/statistics?jobs={single},{stopped},{multi}&reps=200&format=table").text
    assert "single: 20 seeds, 0-19; multi: 6 seeds, 0-5" in table


def test_one_system_in_two_worlds_is_aggregated_once(client: TestClient, worker: Worker) -> None:
    algorithms = ["uniform", "mgrao-1:1", "oracle"]
    short = _submit(client, {"system": "single", "seeds": 6, "episodes": 20, "algorithms": algorithms})
    long = _submit(client, {"system": "single", "seeds": 6, "episodes": 30, "algorithms": algorithms})
    multi = _submit(client, {"system": "multi", "seeds": 6, "episodes": 20, "algorithms": algorithms})
    assert drain(worker) == 3
    ids = f"{short},{long},{multi}"
    refused = client.get(f"/api/compare/statistics?jobs={ids}&reps=100").json()
    assert refused["aggregate"] == {} and refused["aggregated"]["systems"] == []
    assert refused["aggregated"]["worlds_of_system"] == {"single": ["single (episodes=20)", "single (episodes=30)"]}
    assert "several worlds of one system" in refused["aggregated"]["reason"]
    assert set(refused["systems"]) == {"single (episodes=20)", "single (episodes=30)", "multi"}
    chosen = client.get(f"/api/compare/statistics?jobs={ids}&reps=100&aggregate={long}").json()
    assert chosen["aggregated"]["systems"] == ["single (episodes=30)", "multi"]
    assert set(chosen["aggregate"]) == set(algorithms)
    curves = client.get(f"/api/compare/sample-efficiency?jobs={ids}&reps=50&points=5&aggregate={long}").json()
    assert curves["systems"] == ["single (episodes=30)", "multi"] and set(curves["curves"]) == set(algorithms)
    for bad, field in ((f"{short},{long}", "aggregate"), ("999", "aggregate"), ("x", "aggregate")):
        answer = client.get(f"/api/compare/statistics?jobs={ids}&reps=100&aggregate={bad}")
        assert answer.status_code == 422, (bad, answer.text)
        assert answer.json()["detail"][0]["field"] == field, answer.text
