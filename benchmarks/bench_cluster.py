"""Scale-out benchmark: the same work through local workers (SQLite, PostgreSQL) and a Dask cluster.

Run: ``python benchmarks/bench_cluster.py`` (about 10 minutes on 2 cores; ``--small-jobs N`` and
``--big-seeds N`` to shrink it; ``--only dask`` runs one deployment, repeatable). Needs PostgreSQL's
server binaries (Debian: postgresql).

Three deployments, each started here as local processes on 127.0.0.1 and stopped at the end:

a. ``mgrao serve --workers 2`` on a SQLite file;
b. the same on a PostgreSQL server;
c. ``mgrao serve --workers 0`` and ``mgrao dispatcher`` on PostgreSQL, with ``dask scheduler`` and two
   ``dask worker`` processes of one thread each.

Through each: 1,000 small jobs (single, uniform and mgrao-max, 2 seeds x 20 episodes) submitted over
REST (jobs per second until all are stored), then one big job (large, its 7 configurations, 240
seeds x 1,000 episodes) timed from submission to stored results against the same simulation in
one process, with the p99 latency of ``GET /api/jobs`` while it runs. For the cluster, the cost a
chunk pays for travelling through it is the dispatcher's time per small job (each is one chunk)
less a local worker's.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.support.dask_cluster import DaskCluster  # noqa: E402
from tests.support.local_service import free_port, mgrao_command, serve_command, stop, wait_healthy  # noqa: E402
from tests.support.postgres import PostgresServer, why_unavailable  # noqa: E402

SMALL = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 20}
ENV = {"MGRAO_POLL_S": "0.05", "MGRAO_HEARTBEAT_S": "1", "MGRAO_PROGRESS_S": "0.5"}


def big_job(seeds: int) -> dict:
    return {"system": "large", "seeds": seeds, "episodes": 1000}


def one_process(seeds: int) -> float:
    """Wall seconds of the big job's simulation in one process (kernel loaded first)."""
    code = ("import time, json, sys; from mgrao_core import make_spec, run_experiment; "
            "run_experiment(make_spec('single', seeds=1, episodes=2)); t = time.perf_counter(); "
            f"run_experiment(make_spec('large', seeds={seeds}, episodes=1000)); print(time.perf_counter() - t)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    return float(out.stdout.strip().splitlines()[-1])


class Deployment:
    """One of the three deployments, started and stopped here."""

    def __init__(self, kind: str, url: str, work: Path) -> None:
        self.kind, self.url, self.work = kind, url, work
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.processes: list[subprocess.Popen] = []
        self.cluster: DaskCluster | None = None

    def start(self) -> None:
        env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")} | ENV
        workers = 0 if self.kind == "dask" else 2
        log = open(self.work / f"serve-{self.kind}.log", "wb")  # noqa: SIM115
        server = subprocess.Popen(serve_command(self.port, workers, self.url), env=env, stdout=log,
                                  stderr=subprocess.STDOUT)
        self.processes.append(server)
        wait_healthy(self.base, server, timeout=120)
        if self.kind == "dask":
            self.cluster = DaskCluster(self.work)
            self.cluster.start_scheduler()
            self.cluster.start_worker()
            self.cluster.start_worker()
            self.cluster.wait_workers(2)
            dlog = open(self.work / "dispatcher.log", "wb")  # noqa: SIM115
            self.processes.append(subprocess.Popen(
                mgrao_command("dispatcher", "--dask", self.cluster.address),
                env=env | {"MGRAO_DATABASE_URL": self.url}, stdout=dlog, stderr=subprocess.STDOUT))
        time.sleep(3)  # workers warm up (the compiled kernel loads)

    def stop(self) -> None:
        for process in reversed(self.processes):
            stop(process, timeout=30)
        if self.cluster is not None:
            self.cluster.stop()

    def succeeded(self) -> int:
        return httpx.get(f"{self.base}/api/jobs?status=succeeded&limit=1", timeout=30).json()["count"]

    def small_jobs(self, count: int) -> float:
        """Jobs per second for ``count`` small jobs, from the first submission to the last stored."""
        started = time.perf_counter()
        with httpx.Client(timeout=30) as client:
            for _ in range(count):
                assert client.post(f"{self.base}/api/jobs", json=SMALL).status_code == 202
        while self.succeeded() < count:
            time.sleep(0.1)
        return count / (time.perf_counter() - started)

    def big(self, seeds: int, already: int) -> tuple[float, float]:
        """Wall seconds of the big job through the deployment, and the p99 of GET /api/jobs meanwhile."""
        latencies: list[float] = []
        done = threading.Event()

        def poll() -> None:
            with httpx.Client(timeout=30) as client:
                while not done.is_set():
                    t = time.perf_counter()
                    client.get(f"{self.base}/api/jobs?limit=50")
                    latencies.append(time.perf_counter() - t)
                    time.sleep(0.05)

        started = time.perf_counter()
        job = httpx.post(f"{self.base}/api/jobs", json=big_job(seeds), timeout=30).json()["id"]
        poller = threading.Thread(target=poll)
        poller.start()
        while self.succeeded() < already + 1:
            time.sleep(0.2)
        wall = time.perf_counter() - started
        done.set()
        poller.join()
        assert httpx.get(f"{self.base}/api/jobs/{job}", timeout=30).json()["status"] == "succeeded"
        p99 = statistics.quantiles(latencies, n=100)[98] if len(latencies) >= 100 else max(latencies)
        return wall, p99


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small-jobs", type=int, default=1000)
    parser.add_argument("--big-seeds", type=int, default=240)
    parser.add_argument("--only", action="append", choices=["sqlite", "postgresql", "dask"],
                        help="run only this deployment (repeatable; default: all three)")
    args = parser.parse_args()
    chosen = set(args.only or ["sqlite", "postgresql", "dask"])
    reason = why_unavailable()
    if reason:
        raise SystemExit(f"bench_cluster: {reason}")
    baseline = one_process(args.big_seeds)
    print(f"big job (large, 7 configurations, {args.big_seeds} seeds x 1000 episodes) in one process: "
          f"{baseline:.1f} s")
    rows = []
    server = PostgresServer().start()
    try:
        with tempfile.TemporaryDirectory(prefix="mgrao-bench-") as tmp:
            work = Path(tmp)
            for kind, key in (("local, SQLite", "sqlite"), ("local, PostgreSQL", "postgresql"), ("dask", "dask")):
                if key not in chosen:
                    continue
                url = f"sqlite:///{work / 'bench.db'}" if key == "sqlite" else server.create_database()
                deployment = Deployment("dask" if kind == "dask" else "local", url, work)
                deployment.start()
                try:
                    rate = deployment.small_jobs(args.small_jobs)
                    wall, p99 = deployment.big(args.big_seeds, args.small_jobs)
                finally:
                    deployment.stop()
                name = "Dask (2 workers), PostgreSQL" if kind == "dask" else f"2 local workers, {kind.split(', ')[1]}"
                rows.append((name, rate, wall, p99))
                print(f"  {name}: {rate:.1f} small jobs/s; big job {wall:.1f} s ({wall / baseline:.2f} x one process); "
                      f"GET /api/jobs p99 {p99 * 1000:.0f} ms while it ran", flush=True)
    finally:
        server.stop()
    print(f"\n{'deployment':<34}{'small jobs/s':>14}{'big job s':>11}{'x one process':>15}{'p99 ms':>9}")
    for name, rate, wall, p99 in rows:
        print(f"{name:<34}{rate:>14.1f}{wall:>11.1f}{wall / baseline:>15.2f}{p99 * 1000:>9.0f}")
    if {"postgresql", "dask"} <= chosen:
        local_pg, dask = rows[-2], rows[-1]
        per_job = 2 / dask[1] - 2 / local_pg[1]  # two executors each side: seconds of one executor per job
        print(f"\ncost a small job pays for the cluster (dispatcher's seconds per small job less a local "
              f"worker's, per executor): {per_job * 1000:.0f} ms")


if __name__ == "__main__":
    main()
