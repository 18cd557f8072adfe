"""The Python client and ``mgrao log`` against a real ``mgrao serve`` (SQLite and PostgreSQL).

A client killed mid-upload (SIGKILL, so nothing of it runs on the way out) and started again
resumes the same run: every batch it had sent is a replay, nothing is stored twice.
"""

from __future__ import annotations

import random
import signal
import subprocess
from pathlib import Path

import httpx
import numpy as np
import pytest
from backend_helpers import TOKEN, Service
from sqlalchemy import func, select

from backend.store.db import Database
from backend.store.models import ExternalBatch, ExternalPiece, Run
from mgrao_client import ApiError, Client
from tests.support.local_service import mgrao_command


def write_csv(path: Path, seeds: int, episodes: int) -> dict[int, list[float]]:
    generator = random.Random(7)
    runs = {seed: [generator.uniform(0, 50) for _ in range(episodes)] for seed in range(seeds)}
    lines = ["seed,episode,utility"]
    for episode in range(episodes):  # rows in any order: by episode here
        lines += [f"{seed},{episode},{values[episode]!r}" for seed, values in runs.items()]
    path.write_text("\n".join(lines) + "\n")
    return runs


def stored(db_url: str) -> tuple[dict[int, list[float]], int, int]:
    db = Database(db_url)
    try:
        with db.session() as session:
            runs = {seed: np.frombuffer(blob, dtype="<f8").tolist()
                    for seed, blob in session.execute(select(Run.seed, Run.utilities))}
            batches = session.scalar(select(func.count()).select_from(ExternalBatch))
            pieces = session.scalar(select(func.count()).select_from(ExternalPiece))
    finally:
        db.dispose()
    return runs, batches, pieces


@pytest.mark.slow
def test_a_client_killed_mid_upload_and_started_again_stores_nothing_twice(service: Service, tmp_path: Path) -> None:
    service.env["MGRAO_MAX_BODY_BYTES"] = "4096"  # many small batches: the kill lands mid-upload
    service.start_server()
    runs = write_csv(tmp_path / "learner.csv", seeds=40, episodes=800)
    command = mgrao_command("log", str(tmp_path / "learner.csv"), "--system", "single", "--label", "my-learner",
                            "--set", "n_types=10", "--url", service.base)
    first = subprocess.Popen(command, env=service.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        def some_stored() -> dict | None:
            listed = service.get("/api/jobs?kind=external").json()["data"]
            if not listed:
                return None
            run = service.get(f"/api/external-runs/{listed[0]['id']}").json()
            return run if run["values_stored"] > 0 else None

        run = service.wait_for(some_stored, what="the first batches stored", step=0.01)
        first.send_signal(signal.SIGKILL)
    finally:
        first.wait()
    partial = service.get(f"/api/external-runs/{run['job']['id']}").json()
    assert partial["status"] == "open" and 0 < partial["values_stored"] < 40 * 800, partial["values_stored"]
    assert service.get("/api/jobs").json()["data"][0]["status"] == "open"

    again = subprocess.run(command, env=service.env, capture_output=True, text=True, timeout=300, check=False)
    assert again.returncode == 0, again.stdout + again.stderr
    assert f"resuming external run {run['job']['id']}" in again.stdout
    assert "already stored" in again.stdout
    final = service.get(f"/api/external-runs/{run['job']['id']}").json()
    assert final["status"] == "succeeded" and final["values_stored"] == 40 * 800
    values, batches, pieces = stored(service.db_url)
    assert values == runs  # every value once, exactly as written
    sent = int(again.stdout.split(" in ")[1].split(" batches")[0])
    assert batches == sent and pieces == 0  # one stored batch per batch of a whole upload, however often sent
    assert service.get("/api/jobs").json()["count"] == 1


@pytest.mark.slow
def test_the_client_logs_a_run_through_a_service_with_a_token(service: Service) -> None:
    service.env["MGRAO_API_TOKEN"] = TOKEN
    service.start_server()
    with pytest.raises(ApiError) as refused:
        Client(service.base).open_run(label="my-learner", system="single", seeds=2, episodes=3)
    assert refused.value.status == 401
    client = Client(service.base, TOKEN)
    with pytest.raises(ApiError) as invalid:
        client.open_run(label="uniform", system="single", seeds=2, episodes=3)
    assert invalid.value.status == 422 and "built-in algorithm 'uniform'" in str(invalid.value)
    with client.open_run(label="my-learner", system="multi", seeds=[5, 9], episodes=3, tags=["outside"]) as run:
        assert (run.seeds, run.episodes, run.weights_shape) == ([5, 9], 3, (3, 20))
        for seed in run.seeds:
            run.log(seed, [1.0])
            run.log_weights(seed, [[0.05] * 20] * 3)  # held until the seed's episodes are all logged
            run.log(seed, [2.0, 3.0])
        with pytest.raises(ValueError, match="seed 4 is not one of the run's 2 seeds"):
            run.log(4, [1.0])
        with pytest.raises(ValueError, match="value 1 is nan"):
            run.log(5, [1.0, float("nan")], start=0)
    assert run.state["status"] == "succeeded" and all(s["weights"] for s in run.state["seeds"])
    job = httpx.get(f"{service.base}/api/jobs/{run.id}").json()
    assert (job["kind"], job["system"], job["tags"]) == ("external", "multi", ["outside"])
    reopened = client.run(run.id)
    assert reopened.state["values_stored"] == 6
