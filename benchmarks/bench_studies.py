"""Studies benchmark (not a test): prints figures.

Everything runs for real through ``mgrao serve --workers 2`` on a SQLite file (127.0.0.1, stopped
at the end):

1. Trials per second, and a trial's overhead: a grid study of N small trials (single, uniform and
   mgrao-max, 1 seed x 10 episodes) from submission to finished, against the same N experiments
   submitted alone as jobs (from the first POST to the last stored).
2. A 10,000-trial random study of such trials (in flight: 100): its throughput, the p99 of the
   study's light poll (``?trials=false``) while it runs, then, finished: ``GET /api/studies/{id}``
   (every trial) and ``/plots`` p50/p99 over repeated requests, their first (uncached) answer, and
   the study view in headless Chromium from navigation to the trials table and every plot drawn.

Run:  python benchmarks/bench_studies.py [--small 200] [--trials 10000] [--repeat 200]
(about 15 minutes on 2 cores with the defaults). Needs /usr/bin/chromium and playwright's package.
``--reuse FILE`` measures the reads and the view again on the SQLite file of an earlier run (kept
in /tmp/mgrao-bench-studies-*/studies.db), without running trials.
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
from tests.support.local_service import free_port, serve_command, stop, wait_healthy  # noqa: E402

CHROMIUM = os.environ.get("MGRAO_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
BASE = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 1, "episodes": 10}
ENV = {"MGRAO_POLL_S": "0.05", "MGRAO_HEARTBEAT_S": "1", "MGRAO_PROGRESS_S": "0.5", "MGRAO_STUDY_POLL_S": "1"}


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q / 100 * (len(ordered) - 1))))]


def wait_study(client: httpx.Client, study_id: int, timeout: float, probe: list[float] | None = None) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        t = time.perf_counter()
        head = client.get(f"/api/studies/{study_id}", params={"trials": "false"}).json()
        if probe is not None:
            probe.append(time.perf_counter() - t)
        if head["study"]["status"] != "running":
            return head
        time.sleep(0.5)
    raise SystemExit(f"study {study_id} still running after {timeout} s")


def small_grid(n: int) -> dict:
    side = int(round(n ** 0.5))
    return {"name": f"bench grid {side}x{n // side}", "method": "grid", "base": BASE,
            "space": {"learning_rate": {"low": 0.01, "high": 0.5, "steps": side, "log": True},
                      "trace_decay": {"low": 0.1, "high": 0.99, "steps": n // side}},
            "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform"},
            "max_trials": n, "max_in_flight": 16}


def throughput(client: httpx.Client, n: int) -> tuple[float, float, int]:
    """(study trials/s, lone jobs/s, trials) for about n small trials."""
    study = small_grid(n)
    t = time.perf_counter()
    study_id = client.post("/api/studies", json=study).json()["study"]["id"]
    head = wait_study(client, study_id, 3600)
    study_s = time.perf_counter() - t
    trials = head["study"]["planned"]
    detail = client.get(f"/api/studies/{study_id}").json()
    t = time.perf_counter()
    ids = [client.post("/api/jobs", json=BASE | {"params": trial["params"]}).json()["id"]
           for trial in detail["trials"]]
    while True:
        page = client.get("/api/jobs", params={"status": "succeeded", "limit": 1}).json()
        if page["count"] >= trials * 2:  # the study's jobs and the lone ones
            break
        time.sleep(0.2)
    jobs_s = time.perf_counter() - t
    del ids
    return trials / study_s, trials / jobs_s, trials


def timed_gets(client: httpx.Client, path: str, repeat: int, params: dict | None = None) -> tuple[float, list[float]]:
    t = time.perf_counter()
    client.get(path, params=params).raise_for_status()
    first = time.perf_counter() - t
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        client.get(path, params=params).raise_for_status()
        times.append(time.perf_counter() - t)
    return first, times


def view_seconds(base: str, study_id: int, repeat: int) -> dict[str, list[float]]:
    """Per page load, seconds: to the trials table painted; to the answer of a sort clicked right
    then (it waits for whatever holds the main thread, e.g. plotly.js being evaluated); to every
    plot drawn; and a sort of every trial by a parameter once the page is idle."""
    from playwright.sync_api import sync_playwright

    out: dict[str, list[float]] = {"table": [], "first_click": [], "plots": [], "idle_sort": []}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        for _ in range(repeat):
            page = browser.new_page(viewport={"width": 1366, "height": 900})
            t = time.perf_counter()
            page.goto(f"{base}/#/studies/{study_id}")
            page.wait_for_function("() => document.querySelector('section[aria-labelledby=h-trials]')?.dataset.ready",
                                   timeout=60_000)
            out["table"].append(time.perf_counter() - t)
            t_click = time.perf_counter()
            page.locator("button.sort[data-key=value]").click()  # best first: sorts every trial
            page.wait_for_selector("th[aria-sort=descending] button.sort[data-key=value]", timeout=60_000)
            out["first_click"].append(time.perf_counter() - t_click)
            page.wait_for_function("() => document.querySelector('.study-plots')?.dataset.rendered", timeout=60_000)
            out["plots"].append(time.perf_counter() - t)
            t_sort = time.perf_counter()
            page.locator("button.sort[data-key='param:learning_rate']").click()
            page.wait_for_selector("th[aria-sort=ascending] button.sort[data-key='param:learning_rate']",
                                   timeout=60_000)
            out["idle_sort"].append(time.perf_counter() - t_sort)
            page.close()
        browser.close()
    return out


def measure_reads(client: httpx.Client, base: str, study_id: int, args: argparse.Namespace) -> None:
    """GET latencies of a finished study and its view in Chromium, printed."""
    for path in (f"/api/studies/{study_id}", f"/api/studies/{study_id}/plots"):
        first, times = timed_gets(client, path, args.repeat)
        size = len(client.get(path).content)
        print(f"   GET {path}: first {first * 1000:.0f} ms, then p50 {statistics.median(times) * 1000:.1f} ms, "
              f"p99 {percentile(times, 99) * 1000:.1f} ms over {args.repeat} ({size / 1e6:.2f} MB)", flush=True)
    # the study view while another client keeps polling, as a second open tab would
    stop_poll = threading.Event()

    def poll() -> None:
        with httpx.Client(base_url=base, timeout=60) as other:
            while not stop_poll.is_set():
                other.get(f"/api/studies/{study_id}", params={"trials": "false"})
                time.sleep(2)

    poller = threading.Thread(target=poll, daemon=True)
    poller.start()
    views = view_seconds(base, study_id, args.views)
    stop_poll.set()

    def fig(key: str, scale: float = 1, unit: str = "s") -> str:
        values = [v * scale for v in views[key]]
        return f"{statistics.median(values):.2f} {unit} (max {max(values):.2f})"

    print(f"   study view in headless Chromium, median over {args.views} loads: trials table painted "
          f"{fig('table')}; a sort clicked right then answered in {fig('first_click')}; every plot drawn "
          f"{fig('plots')}; a sort of every trial once idle {fig('idle_sort', 1000, 'ms')}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--small", type=int, default=200, help="trials of the throughput grid (about)")
    parser.add_argument("--trials", type=int, default=10_000, help="trials of the large random study")
    parser.add_argument("--repeat", type=int, default=200, help="GET requests per endpoint")
    parser.add_argument("--views", type=int, default=5, help="page loads of the study view")
    parser.add_argument("--reuse", type=Path, default=None,
                        help="an earlier run's studies.db: measure its largest study's reads and view only")
    args = parser.parse_args()

    work = Path(tempfile.mkdtemp(prefix="mgrao-bench-studies-"))
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")} | ENV
    log = open(work / "serve.log", "wb")  # noqa: SIM115
    database = args.reuse.resolve() if args.reuse else work / "studies.db"
    server = subprocess.Popen(serve_command(port, 2, f"sqlite:///{database}"), env=env, stdout=log,
                              stderr=subprocess.STDOUT)
    try:
        wait_healthy(base, server, timeout=120)
        with httpx.Client(base_url=base, timeout=120, headers={"Content-Type": "application/json"}) as client:
            if args.reuse:
                studies = client.get("/api/studies", params={"limit": 200}).json()["data"]
                study_id = max(studies, key=lambda s: s["planned"])["id"]
                measure_reads(client, base, study_id, args)
                return
            study_rate, job_rate, n = throughput(client, args.small)
            print(f"1. {n} small trials: {study_rate:.1f} trials/s through a study; the same {n} experiments as "
                  f"lone jobs: {job_rate:.1f} jobs/s; overhead per trial {1 / study_rate - 1 / job_rate:+.3f} s "
                  f"({job_rate / study_rate:.2f} x a lone job's time)", flush=True)

            big = {"name": f"bench random {args.trials}", "method": "random", "base": BASE,
                   "space": {"learning_rate": {"low": 0.01, "high": 0.5, "log": True},
                             "trace_decay": {"low": 0.1, "high": 0.99},
                             "routing": {"values": ["per-composite", "per-task"]}},
                   "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform"},
                   "max_trials": args.trials, "max_in_flight": 100}
            t = time.perf_counter()
            study_id = client.post("/api/studies", json=big).json()["study"]["id"]
            polls: list[float] = []
            head = wait_study(client, study_id, 7200, polls)
            run_s = time.perf_counter() - t
            print(f"2. {args.trials} trials: {head['study']['trials']} in {run_s:.0f} s "
                  f"({args.trials / run_s:.1f} trials/s); the light poll while it ran: p50 "
                  f"{statistics.median(polls) * 1000:.0f} ms, p99 {percentile(polls, 99) * 1000:.0f} ms "
                  f"over {len(polls)}", flush=True)
            measure_reads(client, base, study_id, args)
    finally:
        stop(server, timeout=30)
        log.close()


if __name__ == "__main__":
    main()
