"""A burst of statistics requests against the light routes (issue 47, item 7; not a test): prints figures.

The service: ``mgrao serve --workers 0`` on 18 finished jobs (``single``, ``multi`` and ``volatile``, six jobs
each of 10 seeds of their own x 100 episodes, ``uniform``, ``mgrao-1:1``, ``mgrao-max`` and the ``oracle``;
simulated in this process and stored through the data layer, so every system pools 60 seeds). The burst, from
this process, all at once, each on its own connection: ``--stats`` requests (50) of ``GET
/api/compare/statistics?jobs=1..18&reps=50000&seed=<each different>`` and as many of ``GET
/api/compare/sample-efficiency`` of the same jobs and seeds (at ``--curve-reps`` repetitions, 10,000: 50,000
would be refused by the limit on resampled scores). Every burst's seeds are new, so no answer is kept from
before. Meanwhile one client per light route (``GET /api/health``, ``GET /api/jobs``, ``GET /api/jobs/1``,
``POST /api/jobs`` of a small job, queued: there is no worker) sends its request back to back, from a second
before the burst until the burst is answered.

Printed: per light route, requests, p50, p99 and max latency and every status; for the burst, per kind, every
status (``Retry-After`` checked on each 503/429), p50, p99 and max time to its answer (every request's
deadline: 30 s); the errors (a status other than 200/202 on a light route, other than 200/503/429 on the
burst, a broken connection, a 503/429 without ``Retry-After``); the API process's peak resident memory over
the burst, from /proc; and the load average before and after. The service's settings are its defaults, or
``MGRAO_STATS_*`` from the environment. Targets: light routes p99 under 300 ms, every statistics request
answered within 30 s, no error.

Run:  python benchmarks/bench_stats_burst.py [--database sqlite|postgresql] [--repeat 1]
      (``--reuse /tmp/mgrao-bench-burst-XXXX/bench.db``: the jobs of an earlier run again, simulate nothing;
      the burst's submissions stay queued in it)
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run as a script: find tests.support and the project's packages
from tests.support.local_service import free_port, serve_command, stop, wait_healthy  # noqa: E402

SYSTEMS = ("single", "multi", "volatile")
JOBS_PER_SYSTEM, SEEDS_PER_JOB, EPISODES = 6, 10, 100
ALGORITHMS = ["uniform", "mgrao-1:1", "mgrao-max", "oracle"]
SMALL_JOB = {"system": "single", "algorithms": ["uniform"], "seeds": 1, "episodes": 5, "name": "burst probe"}
DEADLINE_S = 30.0
LIGHT_TARGET_MS = 300.0


def seed_jobs(db_url: str) -> list[int]:
    """The 18 finished jobs, simulated here and stored as a worker stores them (claim, runs, finish)."""
    from backend.store import crud, queue
    from backend.store.db import Database
    from mgrao_core import make_spec, run_experiment

    db = Database(db_url)
    db.migrate()
    ids = []
    try:
        for system in SYSTEMS:
            for k in range(JOBS_PER_SYSTEM):
                seeds = list(range(k * SEEDS_PER_JOB, (k + 1) * SEEDS_PER_JOB))
                spec = make_spec(system, ALGORITHMS, seeds, EPISODES)
                with db.write() as session:
                    job_id = crud.create_job(session, spec=spec, name=f"{system} {k}").id
                result = run_experiment(spec)
                claim = queue.claim(db, worker_id="bench", stale_after_s=3600, max_attempts=3)
                assert claim is not None and claim.job_id == job_id
                assert queue.store_runs(db, claim=claim, rows=queue.run_rows(job_id, result.runs), progress=1.0)
                assert queue.finish(db, claim=claim, expected_runs=len(result.runs))
                ids.append(job_id)
                print(f"  job {job_id}: {system}, seeds {seeds[0]}-{seeds[-1]}", flush=True)
    finally:
        db.dispose()
    return ids


class Raw:
    """One HTTP/1.1 connection of its own: a request, then its whole answer (Content-Length bodies only)."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.reader: asyncio.StreamReader | None = None
        self.writer: asyncio.StreamWriter | None = None

    async def send(self, method: str, path: str, body: dict | None = None) -> tuple[int, dict[str, str], bytes]:
        """Status, headers and body of one request (a new connection when the last one was closed)."""
        if self.writer is None:
            self.reader, self.writer = await asyncio.open_connection("127.0.0.1", self.port)
        data = b"" if body is None else json.dumps(body).encode()
        head = f"{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{self.port}\r\n"
        if body is not None:
            head += f"Content-Type: application/json\r\nContent-Length: {len(data)}\r\n"
        try:
            assert self.reader is not None
            self.writer.write(head.encode() + b"\r\n" + data)
            await self.writer.drain()
            raw = await self.reader.readuntil(b"\r\n\r\n")
            lines = raw.decode("latin-1").split("\r\n")
            status = int(lines[0].split(" ", 2)[1])
            headers = dict(line.lower().split(": ", 1) for line in lines[1:] if ": " in line)
            content = await self.reader.readexactly(int(headers["content-length"]))
            if headers.get("connection") == "close":
                self.close()
            return status, headers, content
        except BaseException:
            self.close()
            raise

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
        self.reader = self.writer = None


def _memory_kib(pid: int, field: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1])
    return 0


def _family(pid: int) -> list[int]:
    """The process and its descendants."""
    out, todo = [], [pid]
    while todo:
        current = todo.pop()
        out.append(current)
        try:
            for task in Path(f"/proc/{current}/task").iterdir():
                todo += [int(c) for c in (task / "children").read_text().split()]
        except OSError:
            continue
    return out


async def burst(port: int, jobs: str, stats: int, curve_reps: int, first_seed: int) -> dict:
    """Fire the burst and probe the light routes until it is answered; every timing and status."""
    light = {"GET /api/health": ("GET", "/api/health", None, 200), "GET /api/jobs": ("GET", "/api/jobs", None, 200),
             "GET /api/jobs/1": ("GET", "/api/jobs/1", None, 200),
             "POST /api/jobs": ("POST", "/api/jobs", SMALL_JOB, 202)}
    times: dict[str, list[float]] = {name: [] for name in light}
    statuses: dict[str, dict[int, int]] = {name: {} for name in [*light, "statistics", "sample-efficiency"]}
    answered: dict[str, list[float]] = {"statistics": [], "sample-efficiency": []}
    errors: list[str] = []
    done = asyncio.Event()

    async def probe(name: str) -> None:
        method, path, body, expected = light[name]
        client = Raw(port)
        while not done.is_set():
            started = time.perf_counter()
            try:
                status, _, content = await client.send(method, path, body)
            except (OSError, asyncio.IncompleteReadError, ValueError, KeyError) as error:
                errors.append(f"{name}: {type(error).__name__}: {error}")
                await asyncio.sleep(0.05)
                continue
            times[name].append(time.perf_counter() - started)
            statuses[name][status] = statuses[name].get(status, 0) + 1
            if status != expected:
                errors.append(f"{name}: {status} {content[:200]!r}")
            await asyncio.sleep(0.02)
        client.close()

    async def heavy(kind: str, path: str) -> None:
        client = Raw(port)
        started = time.perf_counter()
        try:
            status, headers, content = await asyncio.wait_for(client.send("GET", path), 300)
        except (OSError, asyncio.IncompleteReadError, ValueError, KeyError, TimeoutError) as error:
            errors.append(f"{kind}: {type(error).__name__}: {error}")
            return
        finally:
            client.close()
        answered[kind].append(time.perf_counter() - started)
        statuses[kind][status] = statuses[kind].get(status, 0) + 1
        if status not in (200, 429, 503):
            errors.append(f"{kind}: {status} {content[:200]!r}")
        elif status != 200 and "retry-after" not in headers:
            errors.append(f"{kind}: {status} without Retry-After")

    probes = [asyncio.ensure_future(probe(name)) for name in light]
    await asyncio.sleep(1.0)  # the light routes' latency before the burst is in their samples too
    seeds = range(first_seed, first_seed + stats)
    requests = [heavy("statistics", f"/api/compare/statistics?jobs={jobs}&reps=50000&seed={i}") for i in seeds]
    requests += [heavy("sample-efficiency", f"/api/compare/sample-efficiency?jobs={jobs}&reps={curve_reps}&seed={i}")
                 for i in seeds]
    started = time.perf_counter()
    await asyncio.gather(*requests)
    elapsed = time.perf_counter() - started
    done.set()
    await asyncio.gather(*probes)
    return {"times": times, "statuses": statuses, "answered": answered, "errors": errors, "elapsed": elapsed}


def _ms(samples: list[float], q: float) -> float:
    ordered = sorted(samples)
    return 1000 * ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float("nan")


def run(args: argparse.Namespace) -> None:
    tmp = Path(tempfile.mkdtemp(prefix="mgrao-bench-burst-"))
    postgres = None
    if args.database == "postgresql":
        from tests.support.postgres import PostgresServer, why_unavailable

        reason = why_unavailable()
        if reason is not None:
            raise SystemExit(f"no PostgreSQL: {reason}")
        postgres = PostgresServer().start()
        db_url = postgres.create_database()
    elif args.reuse:
        db_url = f"sqlite:///{Path(args.reuse).resolve()}"
    else:
        db_url = f"sqlite:///{tmp / 'bench.db'}"
    process = None
    try:
        if not (args.reuse and args.database == "sqlite"):
            print(f"simulating and storing {len(SYSTEMS) * JOBS_PER_SYSTEM} jobs into {db_url}", flush=True)
            seed_jobs(db_url)
        jobs = ",".join(str(i) for i in range(1, len(SYSTEMS) * JOBS_PER_SYSTEM + 1))
        port = free_port()
        log = open(tmp / "server.log", "wb")  # noqa: SIM115
        process = subprocess.Popen(serve_command(port, 0, db_url), stdout=log, stderr=log, env=os.environ.copy())
        base = f"http://127.0.0.1:{port}"
        wait_healthy(base, process)
        print(f"mgrao serve --workers 0 pid {process.pid}; log {tmp / 'server.log'}", flush=True)
        for i in range(args.repeat):
            family = _family(process.pid)
            for pid in family:
                Path(f"/proc/{pid}/clear_refs").write_text("5")  # VmHWM from here
            before = {pid: _memory_kib(pid, "VmRSS") for pid in family}
            load_before = os.getloadavg()
            first_seed = int(time.time()) % 100_000 * 1000 + i * args.stats  # no answer kept from an earlier burst
            result = asyncio.run(burst(port, jobs, args.stats, args.curve_reps, first_seed))
            load_after = os.getloadavg()
            family = _family(process.pid)
            peak = {pid: _memory_kib(pid, "VmHWM") for pid in family}
            print(f"\nround {i + 1}: burst answered in {result['elapsed']:.1f} s; load average "
                  f"{load_before[0]:.1f} before, {load_after[0]:.1f} after (1 min)")
            print(f"{'route':<26} {'requests':>8} {'p50':>9} {'p99':>9} {'max':>9}  statuses")
            for name, samples in result["times"].items():
                print(f"{name:<26} {len(samples):>8} {_ms(samples, 0.5):>6.0f} ms {_ms(samples, 0.99):>6.0f} ms "
                      f"{_ms(samples, 1.0):>6.0f} ms  {result['statuses'][name]}")
            for kind, samples in result["answered"].items():
                print(f"{kind + ' (answer)':<26} {len(samples):>8} {_ms(samples, 0.5) / 1000:>7.1f} s "
                      f"{_ms(samples, 0.99) / 1000:>7.1f} s {_ms(samples, 1.0) / 1000:>7.1f} s  "
                      f"{result['statuses'][kind]}")
            api = process.pid
            others = [pid for pid in peak if pid != api]
            print(f"API process peak RSS {peak.get(api, 0) / 1024:.0f} MiB (before the burst "
                  f"{before.get(api, 0) / 1024:.0f} MiB)"
                  + (f"; its children's peaks {[round(peak[p] / 1024) for p in others]} MiB" if others else ""))
            slow = [name for name, samples in result["times"].items() if _ms(samples, 0.99) >= LIGHT_TARGET_MS]
            late = [kind for kind, samples in result["answered"].items() if samples and max(samples) > DEADLINE_S]
            print(f"errors: {len(result['errors'])}")
            for error in result["errors"][:10]:
                print(f"    {error}")
            print(f"targets: light p99 < {LIGHT_TARGET_MS:.0f} ms {'met' if not slow else 'MISSED by ' + str(slow)}; "
                  f"burst answered within {DEADLINE_S:.0f} s {'met' if not late else 'MISSED by ' + str(late)}; "
                  f"no error {'met' if not result['errors'] else 'MISSED'}", flush=True)
    finally:
        if process is not None:
            stop(process, timeout=60)
        if postgres is not None:
            postgres.stop()


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--database", choices=["sqlite", "postgresql"], default="sqlite")
    parser.add_argument("--reuse", help="a SQLite file of an earlier run's jobs (sqlite only)")
    parser.add_argument("--stats", type=int, default=50, help="requests of each kind in the burst")
    parser.add_argument("--curve-reps", type=int, default=10_000,
                        help="the sample-efficiency requests' repetitions")
    parser.add_argument("--repeat", type=int, default=1, help="bursts, one after the other")
    run(parser.parse_args())
