"""Benchmark of the experiment service: queue overhead, write rate and read latency.

    /work/venv/bin/python benchmarks/bench_service.py

Starts real ``mgrao serve`` processes on 127.0.0.1 against a scratch SQLite file and prints a table.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path

import httpx

from backend import crud, queue
from backend.db import Database
from backend.models import CANCELLED, SUCCEEDED, Job
from mgrao_core import make_spec, run_experiment

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run as a script: find tests.support
from tests.support.local_service import free_port, serve_command, stop, wait_healthy  # noqa: E402


class Server:
    def __init__(self, db_url: str, workers: int, log: Path) -> None:
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.log = open(log, "ab")  # noqa: SIM115
        self.process = subprocess.Popen(
            serve_command(self.port, workers, db_url),
            stdout=self.log,
            stderr=self.log,
            env=dict(os.environ, MGRAO_POLL_S="0.02", MGRAO_PROGRESS_S="0.5"),
        )
        wait_healthy(self.base, self.process)
        self.client = httpx.Client(base_url=self.base, timeout=60)
        time.sleep(2.0)  # let the workers warm up before timing anything

    def wait(self, job_id: int, poll: float = 0.05) -> dict:
        while True:
            job = self.client.get(f"/api/jobs/{job_id}").json()
            if job["status"] not in ("queued", "running"):
                return job
            time.sleep(poll)

    def stop(self) -> None:
        self.client.close()
        stop(self.process, timeout=120)
        self.log.close()


def percentiles(samples: list[float]) -> tuple[float, float]:
    ordered = sorted(samples)
    return statistics.median(ordered) * 1000, ordered[min(len(ordered) - 1, int(0.99 * len(ordered)))] * 1000


def timed_gets(client: httpx.Client, url: str, n: int) -> tuple[float, float]:
    client.get(url)
    samples = []
    for _ in range(n):
        t0 = time.perf_counter()
        response = client.get(url)
        samples.append(time.perf_counter() - t0)
        assert response.status_code == 200, response.text
    return percentiles(samples)


def main() -> None:
    rows: list[tuple[str, str, str]] = []
    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-"))
    db_url = f"sqlite:///{tmp / 'bench.db'}"
    log = tmp / "server.log"
    print(f"scratch database {db_url}; server log {log}", flush=True)

    # 1. submission -> stored results vs in-process, one worker with every core
    single = {"system": "single", "seeds": 30, "episodes": 1000}
    run_experiment(make_spec("single", seeds=1, episodes=2))
    server = Server(db_url, workers=1, log=log)
    in_process, service, client_side = [], [], []
    for _ in range(7):  # interleaved, so that both see the same machine load
        t0 = time.perf_counter()
        run_experiment(make_spec(**single))
        in_process.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        job_id = server.client.post("/api/jobs", json=single).json()["id"]
        job = server.wait(job_id, poll=0.1)
        client_side.append(time.perf_counter() - t0)
        assert job["status"] == "succeeded"
        created = datetime.fromisoformat(job["created_at"].rstrip("Z"))
        service.append((datetime.fromisoformat(job["finished_at"].rstrip("Z")) - created).total_seconds())
    for label, pick in (("min", min), ("median", statistics.median)):
        base, total = pick(in_process), pick(service)
        rows.append((f"single 30 seeds x 1000 ep, in-process run_experiment ({label} of 7)", f"{base:.3f} s", ""))
        rows.append(
            (
                f"same, committed submit -> results committed ({label} of 7)",
                f"{total:.3f} s",
                f"overhead {100 * (total / base - 1):+.1f}% (target < 20%)",
            )
        )
    rows.append(("same, seen by a client polling every 100 ms (median)", f"{statistics.median(client_side):.3f} s", ""))

    # the large job whose results we read below
    large = {"system": "large", "seeds": 30, "episodes": 1000}
    large_id = server.client.post("/api/jobs", json=large).json()["id"]
    assert server.wait(large_id)["status"] == "succeeded"
    server.stop()

    # 2. episode rows written per second (a chunk's transaction and the finish)
    db = Database(db_url)
    result = run_experiment(make_spec(**large))
    with db.write() as session:
        scratch = crud.create_job(session, spec=result.spec).id
    claim = queue.claim(db, worker_id="bench", stale_after_s=3600, max_attempts=3)
    assert claim is not None and claim.job_id == scratch
    t0 = time.perf_counter()
    queue.store_runs(db, claim=claim, rows=queue.run_rows(claim.job_id, result.runs), progress=1.0)
    queue.finish(db, claim=claim, expected_runs=len(result.runs))
    elapsed = time.perf_counter() - t0
    episodes = sum(len(r.utilities) for r in result.runs)
    rows.append(
        (
            "episode utilities written (large: 210 runs x 1000 ep)",
            f"{episodes / elapsed:,.0f} /s",
            f"{episodes:,} in {elapsed * 1000:.0f} ms",
        )
    )

    # 3. 10,000 stored jobs, inserted through the data layer
    spec = make_spec("single", seeds=3, episodes=10)
    with db.write() as session:
        for i in range(10_000):
            job: Job = crud.create_job(session, spec=spec, name=f"bulk {i}", tags=[f"t{i % 10}"])
            job.status = SUCCEEDED if i % 2 else CANCELLED
    db.dispose()

    # 4. read latency while two workers are busy
    server = Server(db_url, workers=2, log=log)
    busy = [
        server.client.post("/api/jobs", json={"system": "single", "seeds": 30, "episodes": 100_000}).json()["id"]
        for _ in range(2)
    ]
    while any(server.client.get(f"/api/jobs/{i}").json()["status"] != "running" for i in busy):
        time.sleep(0.05)
    for label, url in [
        ("GET /api/jobs/{id}/results (30 seeds x 7 configs x 1000 ep)", f"/api/jobs/{large_id}/results"),
        ("GET /api/jobs/{id}/results?include_seeds=true", f"/api/jobs/{large_id}/results?include_seeds=true"),
        ("GET /api/jobs/{id}/results?points=200", f"/api/jobs/{large_id}/results?points=200"),
        ("GET /api/jobs (10,000 jobs, first page of 50)", "/api/jobs"),
        ("GET /api/jobs?tag=t3&q=bulk (filtered)", "/api/jobs?tag=t3&q=bulk"),
    ]:
        p50, p99 = timed_gets(server.client, url, 200)
        rows.append((label, f"p50 {p50:.1f} ms", f"p99 {p99:.1f} ms (2 workers busy)"))
    page = server.client.get("/api/jobs?limit=50").json()
    deep = server.client.get(f"/api/jobs?limit=50&cursor={page['next_cursor']}")
    assert deep.status_code == 200
    for job_id in busy:
        server.client.post(f"/api/jobs/{job_id}/cancel", headers={"Content-Type": "application/json"})
    server.stop()

    width = max(len(r[0]) for r in rows)
    print()
    print(f"{'measure'.ljust(width)}  {'value':>16}  note")
    print("-" * (width + 50))
    for name, value, note in rows:
        print(f"{name.ljust(width)}  {value:>16}  {note}")


if __name__ == "__main__":
    main()
