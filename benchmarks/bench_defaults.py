"""The paper's defaults against a kept baseline: is the engine as fast as before it grew?

Run: ``python benchmarks/bench_defaults.py --baseline DIR``, where DIR is a checkout of the
baseline: c30e652, the engine before the algorithms' home and the whole system model (``git
worktree add /tmp/c30e652 c30e652``); the bound is 5% (issue 30, item 15). ``--repeat N`` (5).

Two points, each measured in both checkouts in the same run, alternating A B, B A, ... so that the
machine's drift falls on both alike; each checkout runs from its own root (``PYTHONPATH``) and
first loads (or compiles and stores) its own cached kernel:

* reproduce: ``mgrao reproduce --seeds 100`` as a whole process (interpreter, imports, loading the
  cached kernel, the four systems, the tables, exit), wall and CPU seconds, median of N;
* in process: ``run_experiment`` of the four paper systems with their configurations, 300 seeds x
  100 episodes each, the best of 5 in one process (the kernel loaded first), median over N processes.

The ratio printed is now/baseline of the medians, and the median of the paired ratios.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SYSTEMS = ("single", "multi", "volatile", "large")
BOUND = 1.05
DEADLINE_S = 900.0

IN_PROCESS = textwrap.dedent(
    """
    import sys, time
    from mgrao_core import make_spec, run_experiment
    systems = sys.argv[1].split(",")
    for system in systems:  # load the cached kernel (and compile it, the first time)
        run_experiment(make_spec(system, seeds=1, episodes=2))
    specs = [make_spec(system, seeds=300, episodes=100) for system in systems]
    best = float("inf")
    for _ in range(5):
        start = time.perf_counter()
        for spec in specs:
            run_experiment(spec)
        best = min(best, time.perf_counter() - start)
    print(best)
    """
)


def _environment(root: Path) -> dict[str, str]:
    environment = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")}
    return environment | {"PYTHONPATH": str(root)}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def time_reproduce(root: Path) -> tuple[float, float]:
    """Wall and CPU seconds of one whole ``mgrao reproduce --seeds 100`` process from ``root``."""
    cpu, start = _children_cpu(), time.perf_counter()
    subprocess.run([sys.executable, "-m", "mgrao_cli", "reproduce", "--seeds", "100"], cwd=root,
                   env=_environment(root), check=True, stdout=subprocess.DEVNULL, timeout=DEADLINE_S)
    return time.perf_counter() - start, _children_cpu() - cpu


def time_in_process(root: Path) -> float:
    """The best of 5 ``run_experiment`` passes over the paper's systems (300 seeds x 100 episodes), in seconds."""
    done = subprocess.run([sys.executable, "-c", IN_PROCESS, ",".join(SYSTEMS)], cwd=root, env=_environment(root),
                          check=True, capture_output=True, text=True, timeout=DEADLINE_S)
    return float(done.stdout.split()[-1])


def _line(name: str, now: list[float], before: list[float]) -> str:
    ratio = statistics.median(now) / statistics.median(before)
    paired = statistics.median(a / b for a, b in zip(now, before, strict=True))
    verdict = "within" if ratio <= BOUND else "OVER"
    return (f"{name:>22}: now {statistics.median(now):6.3f} s   baseline {statistics.median(before):6.3f} s   "
            f"now/baseline {ratio:.3f} (paired {paired:.3f}; {verdict} the {BOUND:.2f} bound)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True, help="a checkout of c30e652")
    parser.add_argument("--repeat", type=int, default=5, help="samples of each point per checkout (default 5)")
    args = parser.parse_args()
    roots = {"now": ROOT, "baseline": args.baseline.resolve()}
    for root in roots.values():
        time_in_process(root)  # each checkout's kernel compiled and cached before any timing
    samples: dict[str, dict[str, list[float]]] = {name: {"wall": [], "cpu": [], "in process": []} for name in roots}
    for i in range(args.repeat):
        order = list(roots.items()) if i % 2 == 0 else list(reversed(roots.items()))
        for name, root in order:
            wall, cpu = time_reproduce(root)
            inside = time_in_process(root)
            for key, value in (("wall", wall), ("cpu", cpu), ("in process", inside)):
                samples[name][key].append(value)
            print(f"sample {i + 1} {name}: reproduce {wall:.3f} s wall, {cpu:.3f} s CPU; in process {inside:.3f} s",
                  flush=True)
    print(f"\nmedians of {args.repeat} (cores: {os.cpu_count()})")
    now, before = samples["now"], samples["baseline"]
    print(_line("reproduce, wall", now["wall"], before["wall"]))
    print(_line("reproduce, CPU", now["cpu"], before["cpu"]))
    print(_line("in process, best of 5", now["in process"], before["in process"]))


if __name__ == "__main__":
    main()
