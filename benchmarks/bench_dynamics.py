"""The system's dynamics: what they cost, and that the defaults cost what they did.

Run: ``python benchmarks/bench_dynamics.py --baseline /work/main`` (a checkout without the dynamics).
Paired runs, each point in a fresh subprocess after a warm-up that loads the compiled kernel,
alternating the two checkouts so that the machine's load falls on both alike; prints the median
wall time of each and the median of the paired ratios.

Points: ``large`` with its paper algorithms (defaults: no dynamics), the same with a schedule whose
only event never fires (episode 99,999: the timeline runs, no change happens), ``bursty`` and ``drift``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import textwrap

_POINT = textwrap.dedent(
    """
    import json, sys, time
    from mgrao_core import make_spec, run_experiment
    args = json.loads(sys.argv[1])
    run_experiment(make_spec("multi", seeds=1, episodes=2))  # load the compiled kernel
    spec = make_spec(args["system"], seeds=args["seeds"], episodes=100, overrides=args["set"])
    start = time.perf_counter()
    run_experiment(spec)
    print(json.dumps({"seconds": time.perf_counter() - start}))
    """
)

POINTS = {
    "large (defaults)": ("large", {}),
    "large, an event that never fires": ("large", {"schedule": [{"episode": 99_999, "change": "new-profiles"}]}),
    "bursty": ("bursty", {}),
    "drift": ("drift", {}),
}


def measure(root: str, system: str, overrides: dict, seeds: int) -> float:
    """Seconds of one run of ``system`` in a fresh interpreter importing ``root``'s ``mgrao_core``."""
    env = dict(os.environ, PYTHONPATH=root)
    point = json.dumps({"system": system, "set": overrides, "seeds": seeds})
    out = subprocess.run([sys.executable, "-c", _POINT, point], env=env, cwd=root, capture_output=True, text=True,
                         check=True).stdout
    return json.loads(out.strip().splitlines()[-1])["seconds"]


def main() -> None:
    """Print each point's median time here (and in the baseline), with the median paired ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", metavar="DIR", help="a checkout without the dynamics (defaults only)")
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--pairs", type=int, default=5)
    args = parser.parse_args()
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    base_time = None
    for name, (system, overrides) in POINTS.items():
        ours, theirs = [], []
        for _ in range(args.pairs):
            if args.baseline and name == "large (defaults)":
                theirs.append(measure(args.baseline, system, overrides, args.seeds))
            ours.append(measure(here, system, overrides, args.seeds))
        line = f"{name:36s} {statistics.median(ours):7.3f} s"
        if theirs:
            ratios = [a / b for a, b in zip(ours, theirs, strict=True)]
            line += f"   baseline {statistics.median(theirs):7.3f} s   paired ratio {statistics.median(ratios):.3f}"
        if name == "large (defaults)":
            base_time = statistics.median(ours)
        elif base_time:
            line += f"   x{statistics.median(ours) / base_time:.3f} of large (defaults)"
        print(line, flush=True)


if __name__ == "__main__":
    main()
