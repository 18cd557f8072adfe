"""Benchmark of the experiment service: queue overhead, write rate and read latency, and latency under load.

    python benchmarks/bench_service.py
    python benchmarks/bench_service.py --load [--database sqlite|postgresql|both] [--repeat 3]

Starts real ``mgrao serve`` processes on 127.0.0.1 against a scratch SQLite file and prints a table.

``--load``: a database of 10,000 stored jobs (``--jobs``; those of bench_dashboard.py: the four
systems, 3 to 30 seeds, four in five succeeded with their summaries), one ``mgrao serve`` with one
local worker (``--workers``), then, from this process, ``--clients`` concurrent clients (50), each
on its own keep-alive connection, sending back to back the shuffled mix of ``--gets`` GETs of
``/api/jobs`` (2,000: the first page of 50, the dashboard's default) and ``--posts`` POSTs of small
jobs (200: single, 2 seeds x 20 episodes, which the worker runs meanwhile). It prints the
single-request p50 of that GET (one client alone, workers idle) and, per round, p50 and p99 of each
kind, errors (anything but 200/202, or a broken connection), requests per second and the CPU time
the API process used per request (its cost, which other load on the machine changes little, where
the latencies depend on what else runs); then the medians over ``--repeat`` rounds. The clients
are raw asyncio HTTP/1.1, so that the client's own cost, on the same cores, stays small.
PostgreSQL runs on a throwaway server (tests/support/postgres.py).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path

import httpx

from backend.store import crud, queue
from backend.store.db import Database
from backend.store.models import CANCELLED, SUCCEEDED, Job
from mgrao_core import make_spec, run_experiment

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run as a script: find tests.support
from tests.support.local_service import free_port, serve_command, stop, wait_healthy  # noqa: E402
from tests.support.postgres import PostgresServer, why_unavailable  # noqa: E402


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


# ---- --load: many concurrent clients ------------------------------------------------------------

SMALL_JOB = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 20, "name": "load"}


class RawClient:
    """One keep-alive HTTP/1.1 connection: a request, then its whole answer (Content-Length bodies only)."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.host = f"127.0.0.1:{port}"
        self.reader: asyncio.StreamReader | None = None
        self.writer: asyncio.StreamWriter | None = None

    def get(self, path: str) -> bytes:
        return f"GET {path} HTTP/1.1\r\nHost: {self.host}\r\n\r\n".encode()

    def post(self, path: str, body: dict) -> bytes:
        data = json.dumps(body).encode()
        return (f"POST {path} HTTP/1.1\r\nHost: {self.host}\r\nContent-Type: application/json\r\n"
                f"Content-Length: {len(data)}\r\n\r\n").encode() + data

    async def send(self, request: bytes) -> tuple[int, bytes]:
        """Status and body of one request (reconnecting first when the last one broke the connection)."""
        if self.writer is None:
            self.reader, self.writer = await asyncio.open_connection("127.0.0.1", self.port)
        try:
            assert self.reader is not None
            self.writer.write(request)
            await self.writer.drain()
            head = await self.reader.readuntil(b"\r\n\r\n")
            lines = head.decode("latin-1").split("\r\n")
            status = int(lines[0].split(" ", 2)[1])
            headers = dict(line.lower().split(": ", 1) for line in lines[1:] if ": " in line)
            body = await self.reader.readexactly(int(headers["content-length"]))
            if headers.get("connection") == "close":
                self.close()
            return status, body
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
        self.reader = self.writer = None


async def _single_gets(port: int, n: int) -> list[float]:
    client = RawClient(port)
    samples = []
    for i in range(n + 5):
        t0 = time.perf_counter()
        status, body = await client.send(client.get("/api/jobs"))
        if i >= 5:
            samples.append(time.perf_counter() - t0)
        assert status == 200, body[:500]
    client.close()
    return samples


async def _load(port: int, clients: int, gets: int, posts: int, seed: int, job: dict = SMALL_JOB,
                acknowledged: list[int] | None = None) -> dict:
    """The shuffled mix of GETs and POSTs of ``job`` by ``clients`` clients; ids of the POSTs answered 202 go in
    ``acknowledged``."""
    operations = ["GET"] * gets + ["POST"] * posts
    random.Random(seed).shuffle(operations)
    work = iter(operations)
    times: dict[str, list[float]] = {"GET": [], "POST": []}
    errors: list[str] = []

    async def one_client() -> None:
        client = RawClient(port)
        for kind in work:
            request = client.get("/api/jobs") if kind == "GET" else client.post("/api/jobs", job)
            t0 = time.perf_counter()
            try:
                status, body = await client.send(request)
            except (OSError, asyncio.IncompleteReadError, ValueError, KeyError) as error:
                errors.append(f"{kind}: {type(error).__name__}: {error}")
                continue
            times[kind].append(time.perf_counter() - t0)
            if status != (200 if kind == "GET" else 202):
                errors.append(f"{kind}: {status} {body[:200]!r}")
            elif kind == "POST" and acknowledged is not None:
                acknowledged.append(json.loads(body)["id"])
        client.close()

    t0 = time.perf_counter()
    await asyncio.gather(*(one_client() for _ in range(clients)))
    return {"times": times, "errors": errors, "elapsed": time.perf_counter() - t0}


def _cpu_seconds(pid: int) -> float:
    """CPU time (user + system, every thread) a process has used: its cost, whatever else runs."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _wait_queue_empty(client: httpx.Client, timeout: float = 600) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        health = client.get("/api/health").json()
        if health["queued"] == 0 and health["running"] == 0:
            return
        time.sleep(0.5)
    raise RuntimeError(f"the small jobs of the last round were not done within {timeout} s")


def _wait_workers_ready(client: httpx.Client, workers: int, timeout: float = 300) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if (client.get("/api/health").json().get("workers") or {}).get("ready", 0) >= workers:
            return
        time.sleep(0.5)
    raise RuntimeError(f"{workers} worker(s) were not ready within {timeout} s")


def load(args: argparse.Namespace, backend: str) -> dict:
    """One database backend under ``args``' load: the rows of the table, and its medians."""
    from bench_dashboard import insert_jobs  # the dashboard benchmark's stored jobs, as it makes them

    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-load-"))
    postgres = None
    if backend == "sqlite":
        db_url = f"sqlite:///{tmp / 'bench.db'}"
    else:
        reason = why_unavailable()
        if reason is not None:
            raise SystemExit(f"no PostgreSQL: {reason}")
        postgres = PostgresServer().start()
        db_url = postgres.create_database()
    log = tmp / "server.log"
    print(f"{backend}: inserting {args.jobs:,} jobs ({db_url}); server log {log}", flush=True)
    random.seed(7)
    insert_jobs(db_url, args.jobs)
    server = None
    try:
        server = Server(db_url, workers=args.workers, log=log)
        print(f"{backend}: mgrao serve pid {server.process.pid}", flush=True)  # e.g. for py-spy
        _wait_workers_ready(server.client, args.workers)
        page = server.client.get("/api/jobs")
        single = sorted(asyncio.run(_single_gets(server.port, args.single)))
        single_p50 = statistics.median(single) * 1000
        print(f"{backend}: page of {len(page.json()['data'])} jobs is {len(page.content) / 1000:.0f} kB; "
              f"single-request GET p50 {single_p50:.1f} ms", flush=True)
        rounds = []
        for i in range(args.repeat):
            _wait_queue_empty(server.client)
            cpu = _cpu_seconds(server.process.pid)
            result = asyncio.run(_load(server.port, args.clients, args.gets, args.posts, seed=i))
            cpu = _cpu_seconds(server.process.pid) - cpu
            figures = {kind: percentiles(samples) for kind, samples in result["times"].items() if samples}
            row = {
                "get_p50": figures["GET"][0], "get_p99": figures["GET"][1],
                "post_p50": figures["POST"][0] if "POST" in figures else float("nan"),
                "post_p99": figures["POST"][1] if "POST" in figures else float("nan"),
                "errors": len(result["errors"]), "rps": (args.gets + args.posts) / result["elapsed"],
                "cpu_ms": 1000 * cpu / (args.gets + args.posts),
            }
            rounds.append(row)
            print(f"{backend} round {i + 1}: GET p50 {row['get_p50']:.0f} ms p99 {row['get_p99']:.0f} ms, "
                  f"POST p50 {row['post_p50']:.0f} ms p99 {row['post_p99']:.0f} ms, {row['errors']} errors, "
                  f"{row['rps']:.0f} requests/s, API process CPU {row['cpu_ms']:.2f} ms/request", flush=True)
            for error in result["errors"][:5]:
                print(f"    {error}", flush=True)
        medians = {key: statistics.median(r[key] for r in rounds) for key in rounds[0]}
        return {"single_p50": single_p50, "page_kb": len(page.content) / 1000, **medians}
    finally:
        if server is not None:
            server.stop()
        if postgres is not None:
            postgres.stop()


def load_main(args: argparse.Namespace) -> None:
    backends = ["sqlite", "postgresql"] if args.database == "both" else [args.database]
    results = {backend: load(args, backend) for backend in backends}
    print()
    print(f"{args.clients} clients, {args.gets} GET /api/jobs + {args.posts} POST /api/jobs per round, "
          f"{args.jobs:,} stored jobs, {args.workers} worker(s); medians of {args.repeat} rounds")
    print(f"{'database':<11} {'page':>7} {'single p50':>11} {'GET p50':>8} {'GET p99':>8} {'POST p50':>9} "
          f"{'POST p99':>9} {'errors':>7} {'req/s':>6} {'API CPU/request':>16}")
    for backend, r in results.items():
        print(f"{backend:<11} {r['page_kb']:>5.0f}kB {r['single_p50']:>8.1f} ms {r['get_p50']:>5.0f} ms "
              f"{r['get_p99']:>5.0f} ms {r['post_p50']:>6.0f} ms {r['post_p99']:>6.0f} ms {r['errors']:>7.0f} "
              f"{r['rps']:>6.0f} {r['cpu_ms']:>13.2f} ms")
    print("targets at 50 clients: GET p99 < 300 ms, POST p99 < 500 ms, 0 errors")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--load", action="store_true", help="only the concurrent-clients measure")
    parser.add_argument("--database", choices=["sqlite", "postgresql", "both"], default="both")
    parser.add_argument("--jobs", type=int, default=10_000, help="stored jobs (--load)")
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--gets", type=int, default=2000)
    parser.add_argument("--posts", type=int, default=200)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--single", type=int, default=200, help="sequential GETs for the single-request p50")
    parser.add_argument("--repeat", type=int, default=3, help="load rounds (medians are reported)")
    arguments = parser.parse_args()
    if arguments.load:
        load_main(arguments)
    else:
        main()
