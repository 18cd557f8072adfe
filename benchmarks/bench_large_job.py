"""The service and the dashboard at 10,000 children (issue 42, item 4): not a test, prints figures.

1. A real ``mgrao serve`` (one local worker; SQLite, or ``--database-url``) runs one job of ``--children``
   children and ``--parents`` parents (ring topology, ``--per-parent`` children per parent) while the
   resident memory of the API process and of its worker is read every 0.1 s (psutil).
2. What is stored per run: each column's bytes, as the database holds them (SQL ``length()``).
3. The API, the median of ``--repeat`` requests each: the job, its results, one seed's weights (the default
   page, a page of children far in, the mean over children), compare and the job list; each answer's bytes.
4. Headless Chromium (``/usr/bin/chromium``; never downloads a browser): navigation to the job page's utility
   chart drawn and to its learned weights drawn, and to the compare page's charts drawn (``compare-rendered``),
   a fresh browser context each time. Target: both under 2 s.

Run:  python benchmarks/bench_large_job.py [--children 10000] [--parents 100000] [--per-parent 8]
      [--algorithms uniform,mgrao-10:1,mgrao-100:1] [--seeds 2] [--episodes 100] [--repeat 5]
      [--postgres | --database-url postgresql+psycopg://...] [--no-browser]
      (``--postgres``: a throwaway PostgreSQL server, as the tests start one: tests/support/postgres.py)
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run as a script: find tests.support and the project's packages
from tests.support.local_service import free_port, serve_command, stop, wait_healthy  # noqa: E402

CHROMIUM = os.environ.get("MGRAO_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
MIB = 1024**2


def request(base: str, method: str, path: str, body: dict | None = None, timeout: float = 600) -> tuple[bytes, float]:
    """The answer's bytes and the seconds it took."""
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(f"{base}/api{path}", data=data, method=method,
                                 headers={"Content-Type": "application/json"})
    start = time.perf_counter()
    with urllib.request.urlopen(req, timeout=timeout) as r:
        answer = r.read()
    return answer, time.perf_counter() - start


def call(base: str, method: str, path: str, body: dict | None = None) -> dict:
    return json.loads(request(base, method, path, body)[0] or b"null")


class Sampler(threading.Thread):
    """The peak resident memory of the API process and of its children (the workers), read every 0.1 s."""

    def __init__(self, pid: int) -> None:
        super().__init__(daemon=True)
        import psutil

        self.process = psutil.Process(pid)
        self.api_peak = self.workers_peak = 0
        self.done = threading.Event()

    def sample(self) -> tuple[int, int]:
        import psutil

        api = self.process.memory_info().rss
        workers = 0
        for child in self.process.children(recursive=True):
            try:
                workers = max(workers, child.memory_info().rss)
            except psutil.NoSuchProcess:
                continue
        return api, workers

    def run(self) -> None:
        while not self.done.wait(0.1):
            api, workers = self.sample()
            self.api_peak, self.workers_peak = max(self.api_peak, api), max(self.workers_peak, workers)


def median_ms(times: list[float]) -> str:
    return f"{statistics.median(times) * 1000:.0f} ms"


def stored_bytes(url: str, job_id: int) -> list[dict]:
    """Each run's stored columns, in bytes (the database's own count)."""
    from sqlalchemy import func, select

    from backend.store.db import Database
    from backend.store.models import Run

    columns = [c for c in ("utilities", "combined_weights", "group_weights", "child_means", "membership")
               if hasattr(Run, c)]  # child_means since migration 0017
    db = Database(url)
    try:
        with db.session() as session:
            rows = session.execute(select(Run.algorithm, Run.seed, *(func.coalesce(func.length(getattr(Run, c)), 0)
                                                                     for c in columns))
                                   .where(Run.job_id == job_id).order_by(Run.algorithm, Run.seed)).all()
    finally:
        db.dispose()
    return [{"algorithm": r[0], "seed": r[1], **dict(zip(columns, r[2:], strict=True))} for r in rows]


def timed_reads(base: str, job_id: int, children: int, repeat: int) -> None:
    """The API reads a job page and compare make, and the weights' pages: each answer's first and median time (the
    first builds what a succeeded job's results cache), and its size."""
    paths = {
        "GET /api/jobs/{id}": f"/jobs/{job_id}",
        "GET /api/jobs/{id}/results?points=600": f"/jobs/{job_id}/results?points=600",
        "GET /api/jobs/{id}/weights": f"/jobs/{job_id}/weights",
        f"GET /api/jobs/{{id}}/weights?child_offset={children - 100}": f"/jobs/{job_id}/weights?child_offset="
                                                                     f"{children - 100}",
        "GET /api/jobs/{id}/weights?child_offset=5000&children=1 (the job page's)":
            f"/jobs/{job_id}/weights?child_offset=5000&children=1",
        "GET /api/compare?jobs={id}&points=500": f"/compare?jobs={job_id}&points=500",
        "GET /api/jobs?limit=50": "/jobs?limit=50",
    }
    for label, path in paths.items():
        times, size = [], 0
        try:
            for _ in range(repeat):
                answer, seconds = request(base, "GET", path)
                times.append(seconds)
                size = len(answer)
        except urllib.error.HTTPError as error:
            print(f"  {label}: {error.code} {error.read()[:200]!r}")
            continue
        print(f"  {label}: first {times[0] * 1000:.0f} ms, median {median_ms(times)}, {size / 1e6:.2f} MB")


def browser_loads(base: str, job_id: int, repeat: int) -> None:
    """Navigation -> the job page's utility chart and weights drawn, and the compare page's charts drawn."""
    from playwright.sync_api import sync_playwright

    job_chart, job_weights, compare = [], [], []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        for _ in range(repeat):
            context = browser.new_context(viewport={"width": 1366, "height": 768}, base_url=base)
            page = context.new_page()
            start = time.perf_counter()
            page.goto(f"/#/jobs/{job_id}")
            page.wait_for_selector("#utility-chart[data-rendered]", timeout=120000)
            job_chart.append(time.perf_counter() - start)
            page.wait_for_selector("#weights-bars .main-svg", timeout=120000)
            job_weights.append(time.perf_counter() - start)
            context.close()
            context = browser.new_context(viewport={"width": 1366, "height": 768}, base_url=base)
            page = context.new_page()
            start = time.perf_counter()
            page.goto(f"/#/compare?jobs={job_id}")
            page.wait_for_selector("main[data-render-ms] #compare-chart[data-rendered]", timeout=120000)
            compare.append(time.perf_counter() - start)
            context.close()
        browser.close()
    print(f"  job page, navigation -> utility chart drawn: median {median_ms(job_chart)}; -> learned weights drawn: "
          f"median {median_ms(job_weights)} (plotly.js not cached: a fresh context each time)")
    print(f"  compare page, navigation -> charts drawn: median {median_ms(compare)}")
    worst = max(statistics.median(job_weights), statistics.median(compare))
    print(f"target: job page and compare under 2 s {'MET' if worst < 2 else 'MISSED'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--children", type=int, default=10_000)
    parser.add_argument("--parents", type=int, default=100_000)
    parser.add_argument("--per-parent", type=int, default=8)
    parser.add_argument("--algorithms", default="uniform,mgrao-10:1,mgrao-100:1")
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--database-url", default=None)
    parser.add_argument("--postgres", action="store_true", help="a throwaway PostgreSQL server for the run")
    parser.add_argument("--no-browser", action="store_true")
    args = parser.parse_args()

    postgres = None
    if args.postgres:
        from tests.support.postgres import PostgresServer

        postgres = PostgresServer().start()
        args.database_url = postgres.create_database()
    try:
        run(args)
    finally:
        if postgres is not None:
            postgres.stop()


def run(args: argparse.Namespace) -> None:
    """One service, one job, its figures."""
    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-large-"))
    url = args.database_url or f"sqlite:///{tmp / 'bench.db'}"
    print(f"database: {url.split('://', 1)[0]}; load average {os.getloadavg()[0]:.1f}")
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")}
    with open(tmp / "serve.log", "wb") as log:
        proc = subprocess.Popen(serve_command(port, 1, url), env=env, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT)
    sampler: Sampler | None = None
    try:
        wait_healthy(base, proc)
        while not (call(base, "GET", "/health").get("workers") or {}).get("ready"):
            time.sleep(0.5)  # the worker's warm-up: its memory is not the job's
        sampler = Sampler(proc.pid)
        idle_api, idle_worker = sampler.sample()
        sampler.start()
        params = {"n_children": args.children, "n_parents": args.parents, "topology": "ring",
                  "children_per_parent": args.per_parent}
        algorithms = args.algorithms.split(",")
        start = time.perf_counter()
        job = call(base, "POST", "/jobs", {"system": "multi", "algorithms": algorithms, "seeds": args.seeds,
                                           "episodes": args.episodes, "params": params, "name": "bench large job"})
        if "id" not in job:
            raise SystemExit(f"the job was refused: {job}")
        polls = []
        while True:
            answer, seconds = request(base, "GET", f"/jobs/{job['id']}")
            polls.append(seconds)
            state = json.loads(answer)
            if state["status"] in ("succeeded", "failed", "cancelled"):
                break
            request(base, "GET", "/jobs?limit=50")  # the runs page's poll, as a dashboard open meanwhile makes it
            time.sleep(0.5)
        took = time.perf_counter() - start
        if state["status"] != "succeeded":
            raise SystemExit(f"job {job['id']} {state['status']}: {state.get('error')}")
        runs = len(algorithms) * args.seeds
        print(f"job {job['id']}: {args.children:,} children x {args.parents:,} parents (ring, {args.per_parent} "
              f"children per parent), {', '.join(algorithms)}, {args.seeds} seeds x {args.episodes} episodes "
              f"({runs} runs): {took:.1f} s through the service; its record read in median {median_ms(polls)} "
              "while it ran")
        print(f"resident memory while it ran: API process {idle_api / MIB:.0f} MiB idle, peak "
              f"{sampler.api_peak / MIB:.0f} MiB; worker {idle_worker / MIB:.0f} MiB warm, peak "
              f"{sampler.workers_peak / MIB:.0f} MiB")
        print("stored per run (bytes):")
        for row in stored_bytes(url, job["id"]):
            sizes = {k: v for k, v in row.items() if k not in ("algorithm", "seed")}
            print(f"  {row['algorithm']} seed {row['seed']}: " + ", ".join(f"{k} {v:,}" for k, v in sizes.items())
                  + f"; {sum(sizes.values()) / 1e6:.1f} MB")
        sampler.api_peak = 0
        print(f"API reads (median of {args.repeat}):")
        timed_reads(base, job["id"], args.children, args.repeat)
        if not args.no_browser:
            browser_loads(base, job["id"], args.repeat)
        print(f"API process peak while reading: {sampler.api_peak / MIB:.0f} MiB; load average "
              f"{os.getloadavg()[0]:.1f}")
    finally:
        if sampler is not None:
            sampler.done.set()
        stop(proc, timeout=15)
        print(f"(server log and database in {tmp})")


if __name__ == "__main__":
    main()
