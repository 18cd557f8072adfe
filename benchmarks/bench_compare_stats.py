"""Statistics of a comparison (issue 29's targets; not a test): prints figures.

The comparison: 10 jobs x 7 configurations x 100 seeds x 1,000 episodes over 4 systems (single, multi, volatile,
large; the seeds of a system split between its jobs, so that each configuration pools 100 seeds), really
simulated by `mgrao serve`'s workers into a SQLite file. Measured:

1. ``GET /api/compare/statistics`` at 2,000 bootstrap repetitions (aggregates, profiles, P(X>Y), paired tests):
   server-side, built in this process against the same database with an empty answer cache (what a request's
   handler does: read the runs, pool, compute, serialise), and over HTTP, cold (a bootstrap seed not asked
   before, so no kept answer) and cached (the same request again). Targets: under 3 s cold, under 300 ms cached.
2. ``GET /api/compare/sample-efficiency`` (50 points, 1,000 repetitions), cold over HTTP. Target: under 3 s.
3. ``mgrao compare IDS --format latex`` (10,000 repetitions, its default), the whole command.
4. The compare view with the statistics panel folded away (``stats=0``) and open: navigation -> charts on screen
   drawn, plotly.js not cached (a fresh context) and cached in a browser profile on disk. Targets: under 1 s and
   under 400 ms. With the panel open, also navigation -> statistics drawn.

Run:  python benchmarks/bench_compare_stats.py [--repeat 5] [--workers 2]
      (``--reuse /tmp/mgrao-bench-stats-XXXX/bench.db``: the jobs of an earlier run again, simulate nothing)
Needs /usr/bin/chromium (Debian) and playwright's Python package for part 4 (skipped without them).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run as a script: find tests.support and the project's packages
from tests.support.local_service import free_port, mgrao_command, serve_command, stop, wait_healthy  # noqa: E402

CHROMIUM = os.environ.get("MGRAO_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
JOBS = {"single": 3, "multi": 3, "volatile": 2, "large": 2}  # 10 jobs, each system's 100 seeds split between them
SEEDS, EPISODES = 100, 1000
ALGORITHMS = ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max", "oracle", "independent-q", "bandit"]


def call(base: str, path: str, body: dict | None = None, timeout: float = 600) -> tuple[bytes, float]:
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(f"{base}/api{path}", data=data, method="GET" if body is None else "POST",
                                     headers={"Content-Type": "application/json"})
    started = time.perf_counter()
    with urllib.request.urlopen(request, timeout=timeout) as response:
        raw = response.read()
    return raw, time.perf_counter() - started


def median(values: list[float]) -> float:
    return statistics.median(values)


def simulate(base: str) -> list[int]:
    ids = []
    for system, count in JOBS.items():
        bounds = [round(i * SEEDS / count) for i in range(count + 1)]
        for k in range(count):
            body = {"system": system, "seeds": list(range(bounds[k], bounds[k + 1])), "episodes": EPISODES,
                    "algorithms": ALGORITHMS, "name": f"bench stats {system} {k}", "tags": ["bench-stats"]}
            ids.append(json.loads(call(base, "/jobs", body)[0])["id"])
    started = time.perf_counter()
    while True:
        states = [json.loads(call(base, f"/jobs/{i}")[0])["status"] for i in ids]
        if all(s in ("succeeded", "failed", "cancelled") for s in states):
            break
        time.sleep(2)
    if any(s != "succeeded" for s in states):
        raise SystemExit(f"jobs did not all succeed: {states}")
    print(f"simulated {len(ids)} jobs ({len(JOBS) * len(ALGORITHMS) * SEEDS} runs x {EPISODES} episodes) in "
          f"{time.perf_counter() - started:.0f} s")
    return ids


def in_process(url: str, ids: list[int], repeat: int) -> None:
    """The statistics built as a request's handler builds them, an empty answer cache each time."""
    from backend.services import comparison
    from backend.services.analysis import RESULTS_CACHE, dumps
    from backend.store.db import Database

    db = Database(url)
    import scipy.stats  # noqa: F401 - imported once by a serving process: not part of a request's time

    times, sizes = [], []
    for seed in range(repeat):
        RESULTS_CACHE._entries.clear()  # noqa: SLF001 - a cold answer cache, as after a restart
        RESULTS_CACHE._size = 0  # noqa: SLF001
        with db.session() as session:
            started = time.perf_counter()
            answer = comparison.statistics(session, job_ids=ids, repetitions=2000, seed=seed)
            body = dumps(answer)
            times.append(time.perf_counter() - started)
            sizes.append(len(body))
    print(f"statistics server-side (in process, empty cache, 2,000 repetitions): median {median(times):.2f} s "
          f"(min {min(times):.2f}, max {max(times):.2f}; {sizes[0] / 1024:.0f} KiB; "
          f"{len(answer['aggregate'])} configurations x {len(answer['aggregated']['systems'])} systems x "
          f"{answer['aggregated']['n_seeds']} seeds, {len(answer['probability_of_improvement'])} P(X>Y), "
          f"{answer['head_to_head']['tests']} paired tests)")
    db.dispose()


def over_http(base: str, ids: list[int], repeat: int) -> tuple[float, float, float]:
    jobs = ",".join(map(str, ids))
    cold, cached, curves = [], [], []
    for seed in range(100, 100 + repeat):
        cold.append(call(base, f"/compare/statistics?jobs={jobs}&reps=2000&seed={seed}")[1])
        cached.append(call(base, f"/compare/statistics?jobs={jobs}&reps=2000&seed={seed}")[1])
        curves.append(call(base, f"/compare/sample-efficiency?jobs={jobs}&points=50&reps=1000&seed={seed}")[1])
    print(f"GET /api/compare/statistics over HTTP: cold median {median(cold):.2f} s (max {max(cold):.2f}); cached "
          f"median {median(cached) * 1000:.0f} ms (max {max(cached) * 1000:.0f})")
    print(f"GET /api/compare/sample-efficiency (50 points, 1,000 repetitions), cold: median {median(curves):.2f} s "
          f"(max {max(curves):.2f})")
    return median(cold), median(cached), median(curves)


def command(base: str, ids: list[int], repeat: int) -> None:
    times = []
    for seed in range(200, 200 + min(repeat, 3)):
        started = time.perf_counter()
        done = subprocess.run(mgrao_command("compare", ",".join(map(str, ids)), "--url", base, "--format", "latex",
                                            "--seed", str(seed)), capture_output=True, text=True, timeout=900,
                              check=True)
        times.append(time.perf_counter() - started)
    print(f"mgrao compare --format latex (10,000 repetitions, whole command): median {median(times):.2f} s; "
          f"{done.stdout.count(chr(10))} lines")


def page_loads(base: str, ids: list[int], repeat: int) -> dict[str, float]:
    if not Path(CHROMIUM).exists():
        print(f"{CHROMIUM} is absent: the page loads are not measured")
        return {}
    from playwright.sync_api import sync_playwright

    out = {}
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)

        def load(page, stats: bool) -> tuple[float, float | None]:
            page.goto(f"/#/compare?jobs={','.join(map(str, ids))}{'' if stats else '&stats=0'}")
            page.wait_for_selector("main[data-render-ms] #compare-chart[data-rendered]", timeout=60000)
            rendered = page.evaluate("performance.getEntriesByName('compare-rendered')[0].startTime")
            if not stats:
                return rendered, None
            page.wait_for_selector("#stats-body[data-loaded]", timeout=120000)
            return rendered, page.evaluate("performance.now()")

        for stats in (False, True):
            cold, drawn = [], []
            for _ in range(repeat):
                context = browser.new_context(viewport={"width": 1366, "height": 768}, base_url=base)
                rendered, loaded = load(context.new_page(), stats)
                cold.append(rendered)
                if loaded is not None:
                    drawn.append(loaded)
                context.close()
            cached = []
            with tempfile.TemporaryDirectory(prefix="mgrao-bench-chromium-") as profile_dir:
                profile = p.chromium.launch_persistent_context(profile_dir, executable_path=CHROMIUM,
                                                               args=CHROMIUM_ARGS, viewport={"width": 1366,
                                                                                             "height": 768},
                                                               base_url=base)
                for i in range(repeat + 2):
                    page = profile.new_page()
                    rendered, _ = load(page, stats)
                    if i >= 2:
                        cached.append(rendered)
                    page.close()
                profile.close()
            name = "open" if stats else "folded away (stats=0)"
            extra = f"; navigation -> statistics shown, not cached median {median(drawn):.0f} ms" if drawn else ""
            print(f"compare view, statistics panel {name}: navigation -> charts on screen drawn, plotly.js not "
                  f"cached median {median(cold):.0f} ms, cached in a browser profile on disk median "
                  f"{median(cached):.0f} ms{extra}")
            out[f"cold_{stats}"], out[f"cached_{stats}"] = median(cold), median(cached)
        browser.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--reuse", type=Path, help="an earlier run's bench.db: measure its jobs, simulate nothing")
    args = parser.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-stats-"))
    url = f"sqlite:///{(args.reuse or tmp / 'bench.db').resolve()}"
    print(f"database: {url}")
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    env = {**os.environ, "MGRAO_DATABASE_URL": url}
    env.pop("MGRAO_API_TOKEN", None)
    with open(tmp / "serve.log", "wb") as log:
        proc = subprocess.Popen(serve_command(port, 0 if args.reuse else args.workers), env=env, cwd=ROOT,
                                stdout=log, stderr=subprocess.STDOUT)
    try:
        wait_healthy(base, proc, timeout=300)
        if args.reuse:
            listed = json.loads(call(base, "/jobs?tag=bench-stats&limit=200")[0])["data"]
            ids = sorted(j["id"] for j in listed)
        else:
            ids = simulate(base)
        in_process(url, ids, args.repeat)
        cold, cached, curves = over_http(base, ids, args.repeat)
        command(base, ids, args.repeat)
        pages = page_loads(base, ids, args.repeat)
        verdict = (f"targets: statistics cold < 3 s {'MET' if cold < 3 else 'MISSED'}, cached < 300 ms "
                   f"{'MET' if cached < 0.3 else 'MISSED'}; curves < 3 s {'MET' if curves < 3 else 'MISSED'}")
        if pages:
            verdict += (f"; compare view (statistics folded away) cold < 1 s "
                        f"{'MET' if pages['cold_False'] < 1000 else 'MISSED'}, cached < 400 ms "
                        f"{'MET' if pages['cached_False'] < 400 else 'MISSED'}")
        print(verdict)
    finally:
        stop(proc, timeout=15)
        print(f"(server log and database in {tmp})")


if __name__ == "__main__":
    main()
