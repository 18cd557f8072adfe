"""Benchmark of runs logged from outside: 30 seeds x 1,000 episodes end to end over REST on SQLite (target < 1 s).

    python benchmarks/bench_logging.py [--seeds 30] [--episodes 1000] [--repeat 5] [--database sqlite|postgresql]

Starts one real ``mgrao serve`` (no workers, default settings: ``MGRAO_MAX_BODY_BYTES`` 64 KiB) on a
scratch SQLite file and, from this process, logs runs through :mod:`mgrao_client` as a learner would:
``open_run``, every seed's utilities (``run.log``, batches uploaded as they fill a body), one seed's
weights each, ``close``; each round a new run. Prints each round's wall time (opening to closed), the
batches it took, the values per second, and the median over the rounds. ``--database postgresql``
runs the same against a throwaway PostgreSQL server (tests/support/postgres.py).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run as a script: find tests.support, mgrao_client
from mgrao_client import Client  # noqa: E402
from tests.support.local_service import free_port, serve_command, stop, wait_healthy  # noqa: E402

TARGET_S = 1.0


@contextmanager
def database(kind: str, tmp: Path):
    if kind == "sqlite":
        yield f"sqlite:///{tmp / 'bench.db'}"
        return
    from tests.support.postgres import throwaway_server

    with throwaway_server() as server:
        url = server.create_database()
        yield url


def one_round(client: Client, utilities: np.ndarray, weights: list[list[float]], label: str) -> tuple[float, int]:
    started = time.perf_counter()
    run = client.open_run(label=label, system="single", seeds=len(utilities), episodes=utilities.shape[1])
    for seed, values in enumerate(utilities):
        run.log(seed, values.tolist())
        run.log_weights(seed, weights)
    state = run.close()
    elapsed = time.perf_counter() - started
    assert state["status"] == "succeeded" and state["values_stored"] == utilities.size, state
    return elapsed, run.batches


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=30)
    parser.add_argument("--episodes", type=int, default=1000)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--database", choices=("sqlite", "postgresql"), default="sqlite")
    args = parser.parse_args()
    generator = np.random.default_rng(0)
    utilities = generator.uniform(0, 50, size=(args.seeds, args.episodes))
    weights = [[1.0 / 20] * 20]
    with tempfile.TemporaryDirectory() as scratch, database(args.database, Path(scratch)) as url:
        port = free_port()
        env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")}
        with open(Path(scratch) / "serve.log", "wb") as log:
            process = subprocess.Popen(serve_command(port, 0, url), env=env, stdout=log, stderr=subprocess.STDOUT)
        base = f"http://127.0.0.1:{port}"
        try:
            wait_healthy(base, process)
            client = Client(base)
            one_round(client, utilities[:1, :10], weights, "warm-up")  # the server's first requests import lazily
            times = []
            print(f"logging {args.seeds} seeds x {args.episodes:,} episodes ({utilities.size:,} values) over REST, "
                  f"{args.database}, one mgrao serve, default body limit")
            for i in range(args.repeat):
                elapsed, batches = one_round(client, utilities, weights, f"bench-{i}")
                times.append(elapsed)
                print(f"  round {i + 1}: {elapsed:.3f} s, {batches} batches, {utilities.size / elapsed:,.0f} values/s")
            median = statistics.median(times)
            verdict = "meets" if median < TARGET_S else "MISSES"
            print(f"median {median:.3f} s (best {min(times):.3f} s): {verdict} the target of {TARGET_S:.0f} s")
        finally:
            stop(process)


if __name__ == "__main__":
    main()
