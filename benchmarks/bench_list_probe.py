"""The runs list under the lab's probe, two commits side by side (issue 46, item 1): prints its figures.

    git worktree add /tmp/a772a20 a772a20      # the commit to compare with (never committed)
    python benchmarks/bench_list_probe.py --baseline /tmp/a772a20 [--database sqlite|postgresql|both] [--pairs 5]
        [--baseline-python /tmp/venv-a772a20/bin/python]   # the baseline in its own environment (its dependencies)

The probe: ``--clients`` (50) concurrent clients, each on its own keep-alive connection, sending back to
back the shuffled mix of ``--gets`` (2,000) ``GET /api/jobs`` (the first page of 50, the dashboard's
default) and ``--posts`` (200) small ``POST /api/jobs`` (single, 2 configurations x 2 seeds x 20
episodes, which the worker runs meanwhile), on ``--jobs`` (2,000) stored jobs. Each tree (this one,
and the ``--baseline`` checkout) gets its own database seeded by its own code with the same jobs
(:func:`seed`: bench_dashboard.py's shapes, four systems, four in five succeeded with their
summaries), and its own ``mgrao serve`` with the defaults (one local worker). Both servers run
throughout; rounds alternate between them (A B, then B A, ...) so that the machine's drift, which is
large on a shared 2-core machine, falls on both alike. Each round prints GET and POST p50/p99, errors,
requests per second, the API process's CPU per request and the load average (``os.getloadavg``)
before and after it; the end prints each tree's medians and the ratio of this tree's to the
baseline's, as the median of the pairs' ratios. Finally every acknowledged POST of every round is
checked: stored once (the listing counts the jobs named like the probe's), succeeded, and its
stored summaries those of the same experiment run in this process.

``--build`` adds the in-process cost of one page's build, split in its parts (the count, the page's
query, the rows as the API shows them, the summaries' query and rows, the JSON), on each tree's database.
PostgreSQL runs on a throwaway server (tests/support/postgres.py), one database per tree.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PROBE_NAME = "probe-46"
SMALL_JOB = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 20,
             "name": PROBE_NAME}


def seed(url: str, jobs: int) -> None:
    """Store ``jobs`` finished jobs with the code on ``sys.path`` (either tree): bench_dashboard.py's shapes."""
    # the tree's own modules, imported before bench_dashboard puts this tree first on sys.path
    import backend.store.crud
    import backend.store.db
    import backend.store.models  # noqa: F401
    import mgrao_core  # noqa: F401

    sys.path.insert(0, str(HERE))
    from bench_dashboard import insert_jobs

    random.seed(7)
    took = insert_jobs(url, jobs)
    print(f"seeded {jobs:,} jobs in {took:.1f} s", flush=True)


def _tree_env(tree: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")}  # serve's defaults
    env["PYTHONPATH"] = str(tree)
    return env


def _loads() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.1f}/{five:.1f}"


class Tree:
    """One checkout under test: its database, its ``mgrao serve`` (run with its own code), its rounds."""

    def __init__(self, label: str, tree: Path, url: str, log: Path, python: str = sys.executable) -> None:
        self.label, self.tree, self.url, self.log_path, self.python = label, tree, url, log, python
        self.rounds: list[dict] = []
        self.acknowledged: list[int] = []
        self.process: subprocess.Popen | None = None
        self.serve_args: list[str] = []  # more options of ``mgrao serve`` (bench_lab_scale.py: --workers 0)

    def seed(self, jobs: int) -> None:
        subprocess.run([self.python, str(HERE / "bench_list_probe.py"), "--seed", self.url, "--jobs", str(jobs)],
                       cwd=self.tree, env=_tree_env(self.tree), check=True)

    def start(self) -> None:
        from tests.support.local_service import free_port, wait_healthy

        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.log = open(self.log_path, "ab")  # noqa: SIM115
        argv = [self.python, "-m", "mgrao_cli", "serve", "--host", "127.0.0.1", "--port", str(self.port),
                "--database-url", self.url, *self.serve_args]
        self.process = subprocess.Popen(argv, cwd=self.tree, env=_tree_env(self.tree), stdout=self.log,
                                        stderr=self.log)
        wait_healthy(self.base, self.process, timeout=120)

    def stop(self) -> None:
        from tests.support.local_service import stop

        if self.process is not None:
            stop(self.process, timeout=120)
            self.log.close()


def _warm(tree: Tree, timeout: float = 900) -> None:
    """One small job through the worker (its kernels compiled, the first time in a new checkout), then idle."""
    import httpx

    with httpx.Client(base_url=tree.base, timeout=60) as client:
        job_id = client.post("/api/jobs", json={**SMALL_JOB, "name": "warm-up"}).json()["id"]
        deadline = time.monotonic() + timeout
        while client.get(f"/api/jobs/{job_id}").json()["status"] in ("queued", "running"):
            if time.monotonic() > deadline:
                raise RuntimeError(f"{tree.label}: the warm-up job was not done within {timeout} s")
            time.sleep(0.5)


def _round(tree: Tree, args: argparse.Namespace, number: int) -> dict:
    import httpx
    from bench_service import _cpu_seconds, _load, _wait_queue_empty, percentiles

    with httpx.Client(base_url=tree.base, timeout=60) as client:
        _wait_queue_empty(client)
    before = _loads()
    cpu = _cpu_seconds(tree.process.pid)
    result = asyncio.run(_load(tree.port, args.clients, args.gets, args.posts, seed=number, job=SMALL_JOB,
                               acknowledged=tree.acknowledged))
    cpu = _cpu_seconds(tree.process.pid) - cpu
    figures = {kind: percentiles(samples) for kind, samples in result["times"].items() if samples}
    row = {"get_p50": figures["GET"][0], "get_p99": figures["GET"][1],
           "post_p50": figures.get("POST", (float("nan"),) * 2)[0],
           "post_p99": figures.get("POST", (float("nan"),) * 2)[1],
           "errors": len(result["errors"]), "rps": (args.gets + args.posts) / result["elapsed"],
           "cpu_ms": 1000 * cpu / (args.gets + args.posts), "load": f"{before} -> {_loads()}"}
    tree.rounds.append(row)
    print(f"  {tree.label:<9} GET p50 {row['get_p50']:4.0f} p99 {row['get_p99']:4.0f} ms, POST p50 "
          f"{row['post_p50']:4.0f} p99 {row['post_p99']:4.0f} ms, {row['errors']} errors, {row['rps']:4.0f} req/s, "
          f"API CPU {row['cpu_ms']:.2f} ms/req, load {row['load']}", flush=True)
    for error in result["errors"][:5]:
        print(f"      {error}", flush=True)
    return row


def _check_stored(tree: Tree, expected: dict) -> str:
    """Every acknowledged probe job stored once, succeeded, with the in-process summaries: a line saying so."""
    import httpx

    with httpx.Client(base_url=tree.base, timeout=60) as client:
        _wait_queue_empty_bounded(client)
        listed = client.get("/api/jobs", params={"q": PROBE_NAME, "limit": 1}).json()["count"]
        wrong = []
        for job_id in tree.acknowledged:
            job = client.get(f"/api/jobs/{job_id}").json()
            finals = {a: s["final_mean"] for a, s in job.get("summaries", {}).items()}
            if job.get("status") != "succeeded" or finals != expected:
                wrong.append(job_id)
    lost = len(tree.acknowledged) - (listed - len(wrong))
    return (f"{tree.label}: {len(tree.acknowledged)} acknowledged, {listed} stored, {len(wrong)} not succeeded "
            f"with the in-process finals, {max(lost, 0)} lost")


def _wait_queue_empty_bounded(client) -> None:
    from bench_service import _wait_queue_empty

    _wait_queue_empty(client, timeout=900)


def _in_process_finals() -> dict:
    from mgrao_core import final_utilities, make_spec, run_experiment, summarise

    result = run_experiment(make_spec(SMALL_JOB["system"], SMALL_JOB["algorithms"], SMALL_JOB["seeds"],
                                      SMALL_JOB["episodes"]))
    finals: dict[str, dict[int, float]] = {}
    for run in result.runs:
        finals.setdefault(run.algorithm, {})[run.seed] = float(final_utilities(run.utilities)[0])
    return {a: s.final_mean for a, s in summarise(finals).items()}


def _build_parts(tree: Tree, repeat: int) -> str:
    """The in-process cost of one page's build on the tree's database, with the tree's code: a line."""
    done = subprocess.run([tree.python, str(HERE / "bench_list_probe.py"), "--build-only", tree.url,
                           "--repeat", str(repeat)], cwd=tree.tree, env=_tree_env(tree.tree), check=True,
                          capture_output=True, text=True)
    return f"{tree.label}: {done.stdout.strip()}"


def build_only(url: str, repeat: int) -> None:
    """Time one page's build in its parts with the code on ``sys.path`` (median ms of ``repeat``), print a line."""
    import orjson
    from sqlalchemy import func, select

    from backend.store import crud, summaries
    from backend.store.db import Database
    from backend.store.job_order import parse_sort
    from backend.store.models import Job

    db = Database(url)
    parts: dict[str, list[float]] = {k: [] for k in ("count", "page query", "rows", "summaries", "json", "whole")}
    order = parse_sort("-created_at")
    for i in range(repeat + 5):
        marks = [time.perf_counter()]
        with db.session() as session:
            total = session.scalar(select(func.count()).select_from(Job))
            marks.append(time.perf_counter())
            raw = session.execute(order.apply(select(*crud.LISTED, order.value.label("sort_key")), None)
                                  .limit(51)).all()
            marks.append(time.perf_counter())
            jobs = [crud.job_dict(row, crud._config(row.config_json)) for row in raw[:50]]
            marks.append(time.perf_counter())
            stored = summaries.of_jobs(session, [job["id"] for job in jobs])
            marks.append(time.perf_counter())
        for job in jobs:
            job["summaries"] = stored.get(job["id"], {})
        body = orjson.dumps({"data": jobs, "next_cursor": None, "count": total})
        marks.append(time.perf_counter())
        if i >= 5:
            for key, (t0, t1) in zip(parts, zip(marks, marks[1:], strict=False), strict=False):
                parts[key].append(t1 - t0)
            parts["whole"].append(marks[-1] - marks[0])
    db.dispose()
    print(", ".join(f"{k} {statistics.median(v) * 1000:.2f}" for k, v in parts.items())
          + f" ms (medians of {repeat}); {len(body) / 1000:.0f} kB")


def compare(args: argparse.Namespace, backend: str) -> None:
    """Both trees on ``backend``: seeded, served, probed in alternating pairs, checked; prints the summary."""
    from tests.support.postgres import PostgresServer, why_unavailable

    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-probe-"))
    postgres = None
    if backend == "postgresql":
        reason = why_unavailable()
        if reason is not None:
            raise SystemExit(f"no PostgreSQL: {reason}")
        postgres = PostgresServer().start()
    trees = []
    for label, tree, python in (("baseline", args.baseline.resolve(), args.baseline_python), ("this", ROOT,
                                                                                               sys.executable)):
        url = postgres.create_database() if postgres else f"sqlite:///{tmp / f'{label}.db'}"
        trees.append(Tree(label, tree, url, tmp / f"{label}.log", python))
    print(f"\n== {backend}: baseline {args.baseline} ({_commit(args.baseline)}), this {_commit(ROOT)}; logs in {tmp}",
          flush=True)
    try:
        for tree in trees:
            tree.seed(args.jobs)
            tree.start()
            _warm(tree)
        builds = [_build_parts(tree, args.build) for tree in trees] if args.build else []
        for pair in range(args.pairs):
            print(f" pair {pair + 1}", flush=True)
            for tree in (trees if pair % 2 == 0 else trees[::-1]):
                _round(tree, args, pair)
        expected = _in_process_finals()
        checks = [_check_stored(tree, expected) for tree in trees]
    finally:
        for tree in trees:
            tree.stop()
        if postgres is not None:
            postgres.stop()
    base, this = trees
    print(f"\n{backend}: {args.clients} clients, {args.gets} GET + {args.posts} POST per round, {args.jobs:,} stored "
          f"jobs at the start, {args.pairs} rounds each, alternated; medians")
    keys = ("get_p50", "get_p99", "post_p50", "post_p99", "rps", "cpu_ms")
    print(f"  {'tree':<9}" + "".join(f"{k:>10}" for k in keys) + f"{'errors':>8}")
    for tree in trees:
        print(f"  {tree.label:<9}" + "".join(f"{statistics.median(r[k] for r in tree.rounds):>10.1f}" for k in keys)
              + f"{sum(r['errors'] for r in tree.rounds):>8}")
    ratios = {k: statistics.median(t[k] / b[k] for t, b in zip(this.rounds, base.rounds, strict=True)) for k in keys}
    print(f"  {'this/base':<9}" + "".join(f"{ratios[k]:>10.2f}" for k in keys) + "  (median of paired ratios)")
    for line in builds + checks:
        print(f"  {line}")
    print(f"  target: GET p99 < 200 ms; load average (1/5 min) {_loads()} at the end")


def _commit(tree: Path) -> str:
    done = subprocess.run(["git", "-C", str(tree), "log", "-1", "--format=%h"], capture_output=True, text=True,
                          check=False)
    return done.stdout.strip() or "?"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="a checkout of the commit to compare with (git worktree add)")
    parser.add_argument("--baseline-python", default=sys.executable,
                        help="the interpreter (of a virtualenv) that runs the baseline (default: this one)")
    parser.add_argument("--database", choices=["sqlite", "postgresql", "both"], default="both")
    parser.add_argument("--jobs", type=int, default=2000, help="stored jobs at the start")
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--gets", type=int, default=2000)
    parser.add_argument("--posts", type=int, default=200)
    parser.add_argument("--pairs", type=int, default=5, help="rounds on each tree, alternated")
    parser.add_argument("--build", type=int, default=0, help="also time a page's build in parts (this many times)")
    parser.add_argument("--seed", metavar="URL", help=argparse.SUPPRESS)  # the trees' own seeding
    parser.add_argument("--build-only", metavar="URL", help=argparse.SUPPRESS)
    parser.add_argument("--repeat", type=int, default=200, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.seed:
        seed(args.seed, args.jobs)
        return
    if args.build_only:
        build_only(args.build_only, args.repeat)
        return
    if args.baseline is None:
        parser.error("--baseline is required: a checkout of the commit to compare with")
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, str(HERE))
    for backend in (["sqlite", "postgresql"] if args.database == "both" else [args.database]):
        compare(args, backend)


if __name__ == "__main__":
    main()
