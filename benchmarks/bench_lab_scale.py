"""The runs list on a lab's database (issue 46, items 2 and 3), two trees side by side: prints its figures.

    python benchmarks/lab_database.py sqlite:////tmp/lab/lab100k.db         # 100,000 jobs (minutes)
    cp /tmp/lab/lab100k.db /tmp/lab/lab100k-this.db                         # one copy per tree
    python benchmarks/bench_lab_scale.py --migrate sqlite:////tmp/lab/lab100k-this.db   # this tree's migrations, timed
    git archive main | tar -x -C /tmp/main                                  # the tree to compare with
    python benchmarks/bench_lab_scale.py --url sqlite:////tmp/lab/lab100k-this.db \\
        [--baseline /tmp/main --baseline-url sqlite:////tmp/lab/lab100k.db] [--requests 300] [--rounds 2]
    python benchmarks/bench_lab_scale.py --storage sqlite:////tmp/lab/lab100k-this.db   # bytes stored
    python benchmarks/bench_lab_scale.py --plans sqlite:////tmp/lab/lab100k-this.db     # the listings' plans

Each tree gets its own ``mgrao serve --workers 0`` (its own code, on its own copy of the database: the
queued jobs stay queued), and for each listing (the first page; a filtered page, succeeded jobs of
one system; a search; a sort on a result column; a deep page by keyset, 50,000 jobs in) ``--clients``
(50) keep-alive clients send ``--requests`` GETs of it back to back; each listing's rounds alternate
between the trees (A B, then B A) so that the shared machine's drift falls on both. Each round prints
p50 and p99 in ms, errors and the load average before and after; the end prints the medians over the
rounds and checks that both trees answered each listing with the same jobs in the same order.

``--pages`` (with ``--url`` and maybe ``--baseline``) times, with one client, a job's page (the job
with the most runs), a compare of 10 succeeded jobs and their statistics at 2,000 bootstrap repetitions,
cold (a new seed each time) and cached, ``--repeat`` times on each tree, alternated.
``--migrate URL`` runs this tree's migrations on that database and prints how long they took.
``--storage URL`` prints the bytes of each table with its indexes (SQLite's ``dbstat``, PostgreSQL's
``pg_total_relation_size``), the bytes per stored utility (a float64: 8 bytes raw), per run and per job,
and the database's size. ``--plans URL`` prints each statement with which ``crud.list_jobs`` reads each
listing and the database's plan of it (on PostgreSQL ``EXPLAIN ANALYZE``: it runs them).
"""

from __future__ import annotations

import argparse
import asyncio
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from urllib.parse import quote

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

from bench_list_probe import Tree, _commit, _loads  # noqa: E402
from bench_service import RawClient, percentiles  # noqa: E402

DEEP = 50_000
"""Rows before the deep page."""


def listings(url: str) -> dict[str, str]:
    """The paths of the listings measured; the deep page's cursor made by this tree's keyset on ``url``."""
    from sqlalchemy import select

    from backend.store.db import Database
    from backend.store.job_order import parse_sort
    from backend.store.models import Job

    order = parse_sort("-created_at")
    db = Database(url)
    with db.session() as session:
        created, row_id = session.execute(select(Job.created_at, Job.id).order_by(Job.created_at.desc(),
                                                                                 Job.id.desc())
                                          .offset(DEEP - 1).limit(1)).one()
    db.dispose()
    return {
        "first page": "/api/jobs",
        "filtered": "/api/jobs?status=succeeded&system=multi",
        "search": "/api/jobs?q=ablation",
        "sort on a result": f"/api/jobs?sort={quote('-pct_from_uniform:mgrao-max')}",
        f"deep page ({DEEP:,} in)": f"/api/jobs?cursor={order.encode(created, row_id)}",
    }


async def _gets(port: int, path: str, clients: int, requests: int) -> dict:
    times: list[float] = []
    errors: list[str] = []
    bodies: list[bytes] = []
    left = iter(range(requests))

    async def one_client() -> None:
        client = RawClient(port)
        for _ in left:
            t0 = time.perf_counter()
            try:
                status, body = await client.send(client.get(path))
            except (OSError, asyncio.IncompleteReadError, ValueError, KeyError) as error:
                errors.append(f"{type(error).__name__}: {error}")
                continue
            times.append(time.perf_counter() - t0)
            if status != 200:
                errors.append(f"{status} {body[:200]!r}")
            elif not bodies:
                bodies.append(body)
        client.close()

    t0 = time.perf_counter()
    await asyncio.gather(*(one_client() for _ in range(clients)))
    return {"times": times, "errors": errors, "elapsed": time.perf_counter() - t0, "body": bodies[0] if bodies else b""}


def _ids(body: bytes) -> tuple[list[int], int]:
    import orjson

    page = orjson.loads(body)
    return [job["id"] for job in page["data"]], page["count"]


def compare(args: argparse.Namespace) -> None:
    """Each listing on each tree, rounds alternated; prints rounds, medians and whether the answers agree."""
    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-lab-"))
    trees = [Tree("this", ROOT, args.url, tmp / "this.log")]
    if args.baseline:
        trees.insert(0, Tree("baseline", args.baseline.resolve(), args.baseline_url, tmp / "baseline.log",
                             args.baseline_python))
    for tree in trees:
        tree.serve_args = ["--workers", "0"]
    paths = listings(args.url)
    print(f"== {' and '.join(f'{t.label} {_commit(t.tree)} on {t.url}' for t in trees)}; {args.clients} clients, "
          f"{args.requests} GETs a round; logs in {tmp}", flush=True)
    results: dict[tuple[str, str], list[tuple[float, float]]] = {}
    answers: dict[tuple[str, str], tuple[list[int], int]] = {}
    try:
        for tree in trees:
            tree.start()
        for name, path in paths.items():
            print(f" {name}: {path}", flush=True)
            for number in range(args.rounds):
                for tree in (trees if number % 2 == 0 else trees[::-1]):
                    before = _loads()
                    result = asyncio.run(_gets(tree.port, path, args.clients, args.requests))
                    p50, p99 = percentiles(result["times"])
                    results.setdefault((name, tree.label), []).append((p50, p99))
                    answers[(name, tree.label)] = _ids(result["body"]) if result["body"] else ([], -1)
                    print(f"  {tree.label:<9} p50 {p50:5.0f} p99 {p99:5.0f} ms, {len(result['errors'])} errors, "
                          f"{args.requests / result['elapsed']:4.0f} req/s, load {before} -> {_loads()}", flush=True)
                    for error in result["errors"][:3]:
                        print(f"      {error}", flush=True)
    finally:
        for tree in trees:
            tree.stop()
    print(f"\nmedians over {args.rounds} rounds of {args.requests} GETs by {args.clients} clients (p50 / p99 ms)")
    for name in paths:
        row = "".join(f"  {t.label} {statistics.median(r[0] for r in results[(name, t.label)]):5.0f} / "
                      f"{statistics.median(r[1] for r in results[(name, t.label)]):5.0f}" for t in trees)
        same = "" if len(trees) == 1 else (
            "  same jobs, same order" if answers[(name, "this")] == answers[(name, "baseline")] else "  ANSWERS DIFFER")
        print(f"  {name:<22}{row}{same}")
    print(f"  target: p99 < 300 ms; load average (1/5 min) {_loads()} at the end")


def page_paths(url: str) -> dict[str, list[str]]:
    """A job's page, a compare of 10 jobs and its statistics (cold: a new bootstrap seed each time; cached)."""
    from sqlalchemy import func, select

    from backend.store.db import Database
    from backend.store.models import Job, Run

    db = Database(url)
    with db.session() as session:
        biggest = session.scalar(select(Run.job_id).group_by(Run.job_id).order_by(func.count().desc()).limit(1))
        ten = list(session.scalars(select(Job.id).where(Job.status == "succeeded", Job.system == "single",
                                                       Job.kind == "simulation").order_by(Job.id.desc()).limit(10)))
    db.dispose()
    jobs = ",".join(map(str, ten))
    return {
        f"job page (job {biggest}, the most runs)": [f"/api/jobs/{biggest}"],
        "compare of 10 jobs": [f"/api/compare?jobs={jobs}"],
        "their statistics, cold (2,000 reps)": [f"/api/compare/statistics?jobs={jobs}&reps=2000&seed={seed}"
                                                for seed in range(100, 200)],
        "their statistics, cached": [f"/api/compare/statistics?jobs={jobs}&reps=2000&seed=100"],
    }


def pages(args: argparse.Namespace) -> None:
    """One client, each page ``--repeat`` times on each tree, alternated; medians and worst, in ms."""
    import httpx

    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-lab-pages-"))
    trees = [Tree("this", ROOT, args.url, tmp / "this.log")]
    if args.baseline:
        trees.insert(0, Tree("baseline", args.baseline.resolve(), args.baseline_url, tmp / "baseline.log",
                             args.baseline_python))
    for tree in trees:
        tree.serve_args = ["--workers", "0"]
    paths = page_paths(args.url)
    times: dict[tuple[str, str], list[float]] = {}
    try:
        for tree in trees:
            tree.start()
        for name, urls in paths.items():
            for number in range(args.repeat):
                for tree in (trees if number % 2 == 0 else trees[::-1]):
                    with httpx.Client(base_url=tree.base, timeout=120) as client:
                        path = urls[(number * len(trees) + trees.index(tree)) % len(urls)]
                        t0 = time.perf_counter()
                        answer = client.get(path)
                        times.setdefault((name, tree.label), []).append(time.perf_counter() - t0)
                        if answer.status_code != 200:
                            print(f"  {tree.label} {path}: {answer.status_code} {answer.text[:200]}", flush=True)
    finally:
        for tree in trees:
            tree.stop()
    print(f"one client, {args.repeat} requests each (median / worst ms); load at the end {_loads()}")
    for name in paths:
        print(f"  {name:<40}" + "".join(f"  {t.label} {statistics.median(times[(name, t.label)]) * 1000:7.0f} / "
                                        f"{max(times[(name, t.label)]) * 1000:7.0f}" for t in trees))


def migrate(url: str) -> None:
    """This tree's migrations on ``url``, timed."""
    from sqlalchemy import text

    from backend.store.db import Database

    db = Database(url)
    with db.session() as session:
        before = session.scalar(text("SELECT version_num FROM alembic_version"))
    load = _loads()
    t0 = time.perf_counter()
    db.migrate()
    took = time.perf_counter() - t0
    with db.session() as session:
        after = session.scalar(text("SELECT version_num FROM alembic_version"))
    db.dispose()
    print(f"migrated {url} from {before} to {after} in {took:.1f} s (load {load} -> {_loads()})")


def storage(url: str) -> None:
    """Bytes of each table with its indexes, per utility, run and job, and the database's size (SQLite: dbstat)."""
    from sqlalchemy import create_engine, text

    engine = create_engine(url)
    with engine.connect() as connection:
        if engine.dialect.name == "sqlite":
            owner = dict(connection.execute(text("SELECT name, tbl_name FROM sqlite_master "
                                                 "WHERE type IN ('table', 'index')")).all())
            sizes: dict[str, int] = {}
            for name, size in connection.execute(text("SELECT name, sum(pgsize) FROM dbstat GROUP BY name")):
                sizes[owner.get(name, name)] = sizes.get(owner.get(name, name), 0) + size
            total = os.path.getsize(url.removeprefix("sqlite:///"))
        else:  # each table with its indexes and TOAST
            sizes = dict(connection.execute(text(
                "SELECT c.relname, pg_total_relation_size(c.oid) FROM pg_class c JOIN pg_namespace n "
                "ON n.oid = c.relnamespace WHERE c.relkind = 'r' AND n.nspname = 'public'")).all())
            total = connection.scalar(text("SELECT pg_database_size(current_database())"))
        jobs = connection.scalar(text("SELECT count(*) FROM jobs"))
        runs, payload = connection.execute(text("SELECT count(*), sum(length(utilities)) FROM runs")).one()
    engine.dispose()
    utilities = payload // 8
    print(f"{url}: {total / 1e9:.2f} GB; {jobs:,} jobs, {runs:,} runs, {utilities:,} utilities "
          f"(their float64s: {payload / 1e9:.2f} GB); load {_loads()}")
    for table, size in sorted(sizes.items(), key=lambda item: -item[1])[:8]:
        print(f"  {table:<18} {size / 1e6:10.1f} MB with its indexes")
    print(f"  per utility: {sizes['runs'] / utilities:.2f} bytes of the runs table, {total / utilities:.2f} of the "
          f"database (floor: 8)")
    print(f"  per run: {sizes['runs'] / runs / 1e3:.2f} kB of the runs table; per job: {total / jobs / 1e3:.1f} kB "
          f"of the database")


def plans(url: str) -> None:
    """Each statement with which crud.list_jobs reads each listing on ``url``, with the database's plan of it."""
    from urllib.parse import parse_qsl, urlsplit

    from sqlalchemy import event

    from backend.store import crud
    from backend.store.db import Database

    db = Database(url)
    seen: list[tuple[str, object]] = []
    event.listen(db.engine, "before_cursor_execute",
                 lambda _c, _k, statement, parameters, _x, _m: seen.append((statement, parameters)))
    postgres = db.engine.dialect.name == "postgresql"
    for name, path in listings(url).items():
        seen.clear()
        with db.session() as session:
            t0 = time.perf_counter()
            crud.list_jobs(session, **dict(parse_qsl(urlsplit(path).query)))
            took = time.perf_counter() - t0
        print(f"== {name} ({path}): list_jobs {took * 1000:.1f} ms, {len(seen)} statements; load {_loads()}")
        statements = list(seen)
        with db.engine.connect() as connection:
            for statement, parameters in statements:
                print("   " + " ".join(statement.split())[:300])
                explain = "EXPLAIN (ANALYZE, COSTS OFF) " if postgres else "EXPLAIN QUERY PLAN "
                for row in connection.exec_driver_sql(explain + statement, parameters).all():
                    print("      " + str(row[0] if postgres else row[-1]))
    db.dispose()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--url", help="this tree's copy of the lab database (migrated to its head)")
    parser.add_argument("--baseline", type=Path, help="a checkout of the tree to compare with")
    parser.add_argument("--baseline-url", help="the baseline's own copy of the lab database")
    parser.add_argument("--baseline-python", default=sys.executable)
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--requests", type=int, default=300, help="GETs of a listing in a round")
    parser.add_argument("--rounds", type=int, default=2, help="rounds of each listing on each tree, alternated")
    parser.add_argument("--pages", action="store_true", help="a job's page, compare and statistics, one client")
    parser.add_argument("--repeat", type=int, default=5, help="requests of each page with --pages")
    parser.add_argument("--migrate", metavar="URL", help="time this tree's migrations on URL, then stop")
    parser.add_argument("--storage", metavar="URL", help="bytes stored in a lab database, then stop")
    parser.add_argument("--plans", metavar="URL", help="the statements of each listing and their plans, then stop")
    args = parser.parse_args()
    if args.migrate:
        migrate(args.migrate)
    elif args.storage:
        storage(args.storage)
    elif args.plans:
        plans(args.plans)
    elif args.url:
        if args.baseline and not args.baseline_url:
            parser.error("--baseline needs --baseline-url: its own copy of the database")
        pages(args) if args.pages else compare(args)
    else:
        parser.error("one of --url, --migrate, --storage")


if __name__ == "__main__":
    main()
