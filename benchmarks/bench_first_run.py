"""A newcomer's first result: the first simulation after an install, and the dashboard's first job.

Run: ``python benchmarks/bench_first_run.py`` (``--repeat N``, 3 by default). With ``--baseline DIR``
(a checkout of an earlier version, e.g. ``git worktree add /tmp/before c1a2d78``) every point is
measured there too, alternating with this checkout, and printed beside it with the ratio now/before.

Each point is a whole process with an empty numba cache (its own ``NUMBA_CACHE_DIR``), as after an
install, run from the checkout's root (``PYTHONPATH``) on this machine's cores:

* first run: ``mgrao run --system single --algorithms uniform,mgrao-1:1,mgrao-max --seeds 30
  --episodes 100`` (the README's figure), start to exit;
* cached: the same command once more on the cache the first left (every later process);
* dashboard: ``mgrao serve`` (one local worker, a scratch SQLite file) starts, the dashboard's default
  job (the single system's configurations, 3 seeds x 100 episodes) is posted as soon as the service
  answers, and the clock stops when the job has succeeded (the worker compiles while it warms up).
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
sys.path.insert(0, str(ROOT))

from tests.support.local_service import free_port, stop, wait_healthy  # noqa: E402

RUN = ["run", "--system", "single", "--algorithms", "uniform,mgrao-1:1,mgrao-max", "--seeds", "30", "--episodes", "100"]
DASHBOARD_JOB = {"system": "single", "seeds": 3, "episodes": 100}
DEADLINE_S = 600.0


def _environment(root: Path, cache: Path) -> dict[str, str]:
    environment = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_", "MGRAO_"))}
    return environment | {"PYTHONPATH": str(root), "NUMBA_CACHE_DIR": str(cache)}


def time_run(root: Path, cache: Path) -> float:
    """Seconds of one whole ``mgrao run`` process (RUN) from ``root`` with numba's cache in ``cache``."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mgrao_cli", *RUN], cwd=root, env=_environment(root, cache), check=True,
                   stdout=subprocess.DEVNULL, timeout=DEADLINE_S)
    return time.perf_counter() - start


def _request(url: str, body: dict | None = None) -> dict:
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(url, data=data, headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=10) as response:
        return json.loads(response.read())


def time_dashboard(root: Path, cache: Path, scratch: Path) -> float:
    """Seconds from ``mgrao serve``'s start to its first job (DASHBOARD_JOB) succeeded, with an empty cache."""
    port = free_port()
    base = f"http://127.0.0.1:{port}"
    database = f"sqlite:///{scratch / 'dashboard.db'}"
    command = [sys.executable, "-m", "mgrao_cli", "serve", "--host", "127.0.0.1", "--port", str(port),
               "--workers", "1", "--database-url", database]
    with open(scratch / "serve.log", "wb") as log:
        start = time.perf_counter()
        process = subprocess.Popen(command, cwd=scratch, env=_environment(root, cache), stdout=log,
                                   stderr=subprocess.STDOUT)
        try:
            wait_healthy(base, process, timeout=120)
            job = _request(f"{base}/api/jobs", DASHBOARD_JOB)
            deadline = time.monotonic() + DEADLINE_S
            while (status := _request(f"{base}/api/jobs/{job['id']}")["status"]) != "succeeded":
                if status in ("failed", "cancelled") or time.monotonic() > deadline:
                    raise RuntimeError(f"the dashboard's first job is {status} (log: {scratch / 'serve.log'})")
                time.sleep(0.05)
            return time.perf_counter() - start
        finally:
            stop(process)


def measure(root: Path) -> dict[str, float]:
    """One sample of every point for the checkout at ``root``."""
    with tempfile.TemporaryDirectory(prefix="mgrao-first-run-") as scratch:
        cache = Path(scratch) / "numba"
        first = time_run(root, cache)
        cached = time_run(root, cache)
        dashboard = time_dashboard(root, Path(scratch) / "numba-dashboard", Path(scratch))
    return {"first run": first, "cached": cached, "dashboard's first result": dashboard}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="samples of each point per checkout (default 3)")
    parser.add_argument("--baseline", type=Path, help="a checkout of an earlier version, measured alternately")
    args = parser.parse_args()
    roots = {"now": ROOT} | ({"before": args.baseline.resolve()} if args.baseline else {})
    samples: dict[str, list[dict[str, float]]] = {name: [] for name in roots}
    for i in range(args.repeat):
        order = list(roots.items()) if i % 2 == 0 else list(reversed(roots.items()))  # A B, B A, ...
        for name, root in order:
            sample = measure(root)
            samples[name].append(sample)
            print(f"sample {i + 1} {name}: " + ", ".join(f"{k} {v:.1f} s" for k, v in sample.items()), flush=True)
    print(f"\nmedians of {args.repeat}, seconds (cores: {os.cpu_count()})")
    for point in samples["now"][0]:
        now = statistics.median(s[point] for s in samples["now"])
        line = f"{point:>26}: now {now:6.2f}"
        if "before" in samples:
            before = statistics.median(s[point] for s in samples["before"])
            ratios = [a[point] / b[point] for a, b in zip(samples["now"], samples["before"], strict=True)]
            paired = statistics.median(ratios)
            line += f"   before {before:6.2f}   now/before {now / before:.2f} (paired ratios {paired:.2f})"
        print(line)


if __name__ == "__main__":
    main()
