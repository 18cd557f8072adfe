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

``--versus-optuna N`` (issue 23) measures instead, ``--rounds`` times each, with ``mgrao serve``'s
defaults (no MGRAO_ setting: one worker, 0.25 s idle poll, studies polled every 2 s):

a. Optuna's durable storage, ``JournalFileStorage`` (a journal file), random sampler, running the
   same small trial in its own process (numba on one thread, as our workers run small jobs);
b. ours: a random study of N such trials (``max_in_flight`` 100) on SQLite, then on PostgreSQL (a
   throwaway server, tests/support/postgres.py), from the POST to the study finished; the ratio to (a);
c. N small jobs (the same trial) submitted over REST by 16 concurrent connections, from the first
   POST to the last stored; then the same N in ``POST /api/jobs/batch`` requests of 100;
d. the delay of a cancel: a study of 2,000 such trials cancelled while it runs, from the cancel's
   answer to no job of it running (and the trials that still ended after the cancel).

Run:  python benchmarks/bench_studies.py --versus-optuna 1000 [--rounds 3] [--no-postgres]
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


def objective_spec(params: dict):
    from mgrao_core import make_spec

    return make_spec(BASE["system"], BASE["algorithms"], BASE["seeds"], BASE["episodes"], params)


def optuna_journal(n: int, work: Path) -> float:
    """Optuna (JournalFileStorage, random sampler): trials per second for n trials of the same small trial."""
    import numba
    import optuna
    from optuna.storages import JournalStorage
    from optuna.storages.journal import JournalFileBackend

    from mgrao_core import final_utilities, run_chunk, summarise

    numba.set_num_threads(1)  # as our workers run small jobs (backend/execution/small_jobs.py, one_numba_thread)
    optuna.logging.set_verbosity(optuna.logging.WARNING)

    def objective(trial: optuna.Trial) -> float:
        spec = objective_spec({"learning_rate": trial.suggest_float("learning_rate", 0.01, 0.5, log=True),
                               "trace_decay": trial.suggest_float("trace_decay", 0.1, 0.99)})
        finals: dict[str, dict[int, float]] = {}
        for run in run_chunk(spec, spec.seeds):
            finals.setdefault(run.algorithm, {})[run.seed] = float(final_utilities(run.utilities)[0])
        value = summarise(finals)["mgrao-max"].pct_from_uniform
        return float("nan") if value is None else value

    objective_spec({})  # compile or load the kernel outside the timing, as our workers warm up
    run_chunk(objective_spec({}), (0,))
    path = work / f"optuna-{time.monotonic_ns()}.log"
    t = time.perf_counter()
    storage = JournalStorage(JournalFileBackend(str(path)))
    study = optuna.create_study(storage=storage, sampler=optuna.samplers.RandomSampler(seed=1), direction="maximize")
    study.optimize(objective, n_trials=n)
    return n / (time.perf_counter() - t)


def random_study(n: int, seed: int = 1) -> dict:
    return {"name": f"versus optuna {n}", "method": "random", "base": BASE,
            "space": {"learning_rate": {"low": 0.01, "high": 0.5, "log": True},
                      "trace_decay": {"low": 0.1, "high": 0.99}},
            "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform"},
            "max_trials": n, "max_in_flight": 100, "seed": seed}


def study_rate(client: httpx.Client, n: int, seed: int) -> float:
    """Trials per second of a random study of n small trials, from the POST to the study finished."""
    t = time.perf_counter()
    answer = client.post("/api/studies", json=random_study(n, seed))
    answer.raise_for_status()
    study_id = answer.json()["study"]["id"]
    deadline = time.monotonic() + 3600
    while time.monotonic() < deadline:
        head = client.get(f"/api/studies/{study_id}", params={"trials": "false"}).json()["study"]
        if head["status"] != "running":
            elapsed = time.perf_counter() - t
            if head["trials"].get("succeeded", 0) != n:
                raise SystemExit(f"study {study_id}: {head['trials']} of {n}")
            return n / elapsed
        time.sleep(0.02)
    raise SystemExit(f"study {study_id} still running after an hour")


def succeeded(client: httpx.Client) -> int:
    return client.get("/api/jobs", params={"status": "succeeded", "limit": 1}).json()["count"]


def rest_rate(base: str, n: int, *, batch: int = 0, connections: int = 16) -> float:
    """Jobs per second: n small jobs POSTed by ``connections`` clients (or in batches), to the last stored."""
    from concurrent.futures import ThreadPoolExecutor

    with httpx.Client(base_url=base, timeout=120) as client:
        before = succeeded(client)
    bodies = [BASE | {"params": {"learning_rate": 0.01 + 0.49 * i / n}} for i in range(n)]
    if batch:
        requests = [("/api/jobs/batch", {"jobs": bodies[i:i + batch]}) for i in range(0, n, batch)]
    else:
        requests = [("/api/jobs", body) for body in bodies]
    shares = [requests[i::connections] for i in range(connections)]

    def send(share: list) -> None:
        with httpx.Client(base_url=base, timeout=120) as client:
            for path, body in share:
                client.post(path, json=body).raise_for_status()

    t = time.perf_counter()
    with ThreadPoolExecutor(connections) as pool:
        list(pool.map(send, shares))
    with httpx.Client(base_url=base, timeout=120) as client:
        while succeeded(client) < before + n:
            time.sleep(0.02)
    return n / (time.perf_counter() - t)


def cancel_delay(client: httpx.Client) -> tuple[float, int]:
    """(seconds from a running study's cancel answered to none of its jobs running, its jobs succeeded after it)."""
    study_id = client.post("/api/studies", json=random_study(2000, 7)).json()["study"]["id"]
    while client.get(f"/api/studies/{study_id}", params={"trials": "false"}).json()["study"]["trials"].get(
            "succeeded", 0) < 200:
        time.sleep(0.01)
    tag = f"study-{study_id}"

    def stored() -> int:
        return client.get("/api/jobs", params={"status": "succeeded", "tag": tag, "limit": 1}).json()["count"]

    client.post(f"/api/studies/{study_id}/cancel", headers={"Content-Type": "application/json"}).raise_for_status()
    t = time.perf_counter()
    done_then = stored()
    while client.get("/api/jobs", params={"status": "running", "tag": tag, "limit": 1}).json()["count"]:
        time.sleep(0.005)
    delay = time.perf_counter() - t
    time.sleep(1)
    return delay, stored() - done_then


def spread(values: list[float], unit: str = "/s", digits: int = 0) -> str:
    return (f"median {statistics.median(values):.{digits}f}{unit} (range {min(values):.{digits}f} to "
            f"{max(values):.{digits}f}, {len(values)} rounds)")


def versus_optuna(args: argparse.Namespace) -> None:
    """Issue 23's figures: see the module docstring, ``--versus-optuna``."""
    n, rounds = args.versus_optuna, args.rounds
    work = Path(tempfile.mkdtemp(prefix="mgrao-bench-versus-"))
    env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")}  # serve's defaults
    figures: dict[str, list[float]] = {}
    databases = [("sqlite", None)]
    postgres = None
    if not args.no_postgres:
        from tests.support.postgres import PostgresServer, why_unavailable

        reason = why_unavailable()
        if reason:
            print(f"PostgreSQL skipped: {reason}")
        else:
            postgres = PostgresServer().start()
            databases.append(("postgresql", postgres))
    try:
        for round_ in range(rounds):
            optuna_rate = optuna_journal(n, work)
            figures.setdefault("optuna", []).append(optuna_rate)
            print(f"round {round_ + 1}: a. Optuna JournalFileStorage: {optuna_rate:.0f} trials/s", flush=True)
            for name, server in databases:
                url = server.create_database() if server else f"sqlite:///{work}/round{round_}.db"
                port = free_port()
                base = f"http://127.0.0.1:{port}"
                log = open(work / f"serve-{name}-{round_}.log", "wb")  # noqa: SIM115
                process = subprocess.Popen(serve_command(port, int(env.get("MGRAO_WORKERS", 1)), url), env=env,
                                           stdout=log, stderr=subprocess.STDOUT)
                try:
                    wait_healthy(base, process, timeout=120)
                    with httpx.Client(base_url=base, timeout=120) as client:
                        deadline = time.monotonic() + 120  # the worker warmed up: ready
                        while client.get("/api/health").json().get("workers", {}).get("ready", 0) < 1:
                            if time.monotonic() > deadline:
                                raise SystemExit("no worker ready after 120 s")
                            time.sleep(0.2)
                        rate = study_rate(client, n, round_ + 1)
                        figures.setdefault(f"study-{name}", []).append(rate)
                        print(f"round {round_ + 1}: b. ours, random study of {n} on {name}: {rate:.0f} trials/s "
                              f"({rate / optuna_rate:.2f} x Optuna)", flush=True)
                        if name == "sqlite":
                            rest = rest_rate(base, n)
                            batched = rest_rate(base, n, batch=100, connections=4)
                            delay, after = cancel_delay(client)
                            figures.setdefault("rest", []).append(rest)
                            figures.setdefault("batch", []).append(batched)
                            figures.setdefault("cancel", []).append(delay * 1000)
                            print(f"round {round_ + 1}: c. {n} small jobs over REST, 16 connections: {rest:.0f} "
                                  f"jobs/s; in batches of 100 (4 connections): {batched:.0f} jobs/s", flush=True)
                            print(f"round {round_ + 1}: d. cancel: no job of the study running "
                                  f"{delay * 1000:.0f} ms after the cancel's answer; {after} of its jobs succeeded "
                                  f"after it", flush=True)
                finally:
                    stop(process, timeout=30)
                    log.close()
    finally:
        if postgres is not None:
            postgres.stop()
    optuna_median = statistics.median(figures["optuna"])
    print(f"\n{n} small trials, {rounds} rounds, mgrao serve defaults; logs in {work}")
    print(f"  Optuna 5 JournalFileStorage (random, in one process): {spread(figures['optuna'])}")
    for name, _ in databases:
        values = figures[f"study-{name}"]
        print(f"  ours, random study on {name}: {spread(values)}; median ratio to Optuna "
              f"{statistics.median(values) / optuna_median:.2f} x")
    print(f"  REST, 16 connections: {spread(figures['rest'], ' jobs/s')}; "
          f"POST /api/jobs/batch of 100: {spread(figures['batch'], ' jobs/s')}")
    print(f"  cancel of a running study to no job running: {spread(figures['cancel'], ' ms')}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--small", type=int, default=200, help="trials of the throughput grid (about)")
    parser.add_argument("--trials", type=int, default=10_000, help="trials of the large random study")
    parser.add_argument("--repeat", type=int, default=200, help="GET requests per endpoint")
    parser.add_argument("--views", type=int, default=5, help="page loads of the study view")
    parser.add_argument("--reuse", type=Path, default=None,
                        help="an earlier run's studies.db: measure its largest study's reads and view only")
    parser.add_argument("--versus-optuna", type=int, default=0, metavar="N",
                        help="issue 23: N small trials against Optuna's JournalFileStorage, REST and cancel figures")
    parser.add_argument("--rounds", type=int, default=3, help="rounds of --versus-optuna")
    parser.add_argument("--no-postgres", action="store_true", help="--versus-optuna on SQLite only")
    args = parser.parse_args()
    if args.versus_optuna:
        versus_optuna(args)
        return

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
