"""``GET /api/compare/statistics`` and ``/sample-efficiency``, and ``mgrao compare`` against a real service."""

from __future__ import annotations

import csv
import io
import json
import subprocess
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from backend_helpers import Service, drain
from fastapi.testclient import TestClient
from sqlalchemy import select

from backend.execution.worker import Worker
from backend.store.db import Database
from backend.store.models import Run
from mgrao_core import final_utilities
from mgrao_core.statistics.comparison import compare
from mgrao_core.statistics.scores import World
from tests.support.local_service import mgrao_command

ALGORITHMS = ["uniform", "mgrao-1:1", "mgrao-max", "oracle"]


def submit(client, system: str, seeds: int = 8, episodes: int = 30, algorithms=ALGORITHMS) -> dict:
    answer = client.post("/api/jobs", json={"system": system, "seeds": seeds, "episodes": episodes,
                                            "algorithms": algorithms})
    assert answer.status_code == 202, answer.text
    return answer.json()


def finals_of(db: Database, job_id: int) -> dict[str, dict[int, float]]:
    out: dict[str, dict[int, float]] = {}
    with db.session() as session:
        for algorithm, seed, blob in session.execute(select(Run.algorithm, Run.seed, Run.utilities)
                                                     .where(Run.job_id == job_id)):
            out.setdefault(algorithm, {})[seed] = float(final_utilities(np.frombuffer(blob, dtype="<f8"))[0])
    return {a: dict(sorted(out[a].items())) for a in ALGORITHMS}


def test_statistics_are_the_cores_on_the_stored_runs(client: TestClient, worker: Worker, db: Database) -> None:
    single, large = submit(client, "single"), submit(client, "large", episodes=20)
    assert drain(worker) == 2
    answer = client.get(f"/api/compare/statistics?jobs={single['id']},{large['id']}&reps=300&seed=4")
    assert answer.status_code == 200, answer.text
    body = answer.json()
    worlds = [World("single", "single", 30, finals_of(db, single["id"])),
              World("large", "large", 20, finals_of(db, large["id"]))]
    expected = compare(worlds, repetitions=300, seed=4)
    for summaries in expected["systems"].values():  # the service's summaries add the tasks' rates: none can fail
        for summary in summaries.values():
            summary.update({"failure_rate": 0.0, "handover_rate": 0.0})
    for key in ("systems", "scores", "aggregate", "probability_of_improvement", "performance_profiles",
                "head_to_head", "normalisation"):
        assert json.dumps(body[key], sort_keys=True) == json.dumps(expected[key], sort_keys=True), key
    assert body["jobs"] == [single["id"], large["id"]]
    assert body["aggregated"]["systems"] == ["single", "large"]
    assert body["aggregated"]["n_seeds"] == {"single": 8, "large": 8}
    assert body["protocol"]["bootstrap"]["repetitions"] == 300
    assert [c["label"] for c in body["configurations"]] == ALGORITHMS * 2
    assert set(body["probability_of_improvement"]) == {f"{x}>{y}" for x in ALGORITHMS for y in ALGORITHMS if x != y}
    # the rendered forms: numbers in the CSV, a tabular in the LaTeX, text for a terminal
    text = client.get(f"/api/compare/statistics?jobs={single['id']},{large['id']}&reps=300&seed=4&format=csv")
    assert text.headers["content-type"].startswith("text/csv")
    rows = list(csv.DictReader(io.StringIO("\n".join(line for line in text.text.splitlines()
                                                      if not line.startswith("#")))))
    row = next(r for r in rows if r["system"] == "large" and r["configuration"] == "mgrao-max")
    assert float(row["final_mean_utility"]) == pytest.approx(body["systems"]["large"]["mgrao-max"]["final_mean"])
    assert int(row["n_paired"]) == 8
    latex = client.get(f"/api/compare/statistics?jobs={single['id']},{large['id']}&reps=300&seed=4&format=latex")
    assert "\\begin{tabular}" in latex.text and "300 repetitions" in latex.text


def test_statistics_refuse_what_they_cannot_bound(client: TestClient, worker: Worker) -> None:
    job = submit(client, "single", seeds=4, episodes=10)
    assert drain(worker) == 1
    answer = client.get(f"/api/compare/statistics?jobs={job['id']}&reps=50001")
    assert answer.status_code == 422 and answer.json()["detail"][0]["field"] == "reps"
    answer = client.get(f"/api/compare/statistics?jobs={job['id']}&format=pdf")
    assert answer.status_code == 422 and answer.json()["detail"][0]["field"] == "format"
    answer = client.get(f"/api/compare/sample-efficiency?jobs={job['id']}&points=51")
    assert answer.status_code == 422 and answer.json()["detail"][0]["field"] == "points"


def test_sample_efficiency_curves_of_stored_runs(client: TestClient, worker: Worker) -> None:
    single, large = submit(client, "single", episodes=40), submit(client, "large", episodes=20)
    assert drain(worker) == 2
    ids = f"{single['id']},{large['id']}"
    answer = client.get(f"/api/compare/sample-efficiency?jobs={ids}&points=10&reps=200")
    assert answer.status_code == 200, answer.text
    body = answer.json()
    assert body["points"] == 10
    assert body["episodes"] == {"single": list(range(0, 40, 4)), "large": list(range(0, 20, 2))}
    assert list(body["curves"]) == ALGORITHMS and len(body["curves"]["oracle"]["iqm"]) == 10
    # the last bucket is the final window on both (10 of 40 is not: 4 episodes; 2 of 20): close to, not the final IQM
    final = client.get(f"/api/compare/statistics?jobs={ids}&reps=200").json()["aggregate"]
    assert body["curves"]["oracle"]["iqm"][-1] == pytest.approx(final["oracle"]["iqm"]["estimate"], abs=0.5)


@pytest.fixture
def service(tmp_path: Path) -> Iterator[Service]:
    svc = Service(tmp_path)
    svc.start_server(workers=1)
    yield svc
    svc.stop()


@pytest.mark.slow
def test_mgrao_compare_prints_every_format(service: Service) -> None:
    ids = []
    for system in ("single", "large"):
        answer = service.post("/api/jobs", json={"system": system, "seeds": 6, "episodes": 20,
                                                 "algorithms": ALGORITHMS})
        assert answer.status_code == 202, answer.text
        ids.append(answer.json()["id"])
    service.wait_for(lambda: all(service.get(f"/api/jobs/{i}").json()["status"] == "succeeded" for i in ids),
                     what="both jobs to succeed")

    def mgrao(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run(mgrao_command("compare", ",".join(map(str, ids)), "--url", service.base, "--reps", "400",
                                            *args), capture_output=True, text=True, timeout=240, check=False)

    shown = mgrao("--format", "json")
    assert shown.returncode == 0, shown.stderr
    answer = json.loads(shown.stdout)  # stdout holds only the answer
    assert set(answer["systems"]) == {"single", "large"} and answer["protocol"]["bootstrap"]["repetitions"] == 400
    for key in ("n_runs", "n_paired", "final_mean", "ci95", "pct_from_uniform", "pct_ci95"):
        assert key in answer["systems"]["large"]["mgrao-max"]
    assert len(answer["scores"]["mgrao-max"]["single"]) == 6
    assert set(answer["aggregate"]["oracle"]) == {"mean", "median", "iqm", "optimality_gap"}
    assert "mgrao-max>uniform" in answer["probability_of_improvement"]
    table = mgrao()
    assert table.returncode == 0 and "IQM" in table.stdout and "large" in table.stdout
    latex = mgrao("--format", "latex")
    assert latex.stdout.count("\\begin{tabular}") == 2 and "\\caption{" in latex.stdout
    text = mgrao("--format", "csv")
    assert text.stdout.startswith("# single: 20 episodes, seeds 0-5")
    wrong = mgrao("--format", "csv", "--reps", "0")
    assert wrong.returncode == 2 and "--reps" in wrong.stderr
    unknown = subprocess.run(mgrao_command("compare", "999", "--url", service.base), capture_output=True, text=True,
                             timeout=120, check=False)
    assert unknown.returncode == 1 and "999" in unknown.stderr
