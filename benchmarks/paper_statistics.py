"""The statistics across the paper's four systems (docs/statistics.md, "The paper's systems"): prints them.

uniform, mgrao-1:1, mgrao-max, the oracle, independent-q and bandit on single, multi, volatile and large with
their presets, the paper's 100 episodes and 100 held-out seeds (0-99), simulated in this process, then
scored, aggregated and tested exactly as ``GET /api/compare/statistics`` does (``mgrao_core.statistics.comparison``) and
printed as ``mgrao compare`` prints it.

Run:  python benchmarks/paper_statistics.py [--seeds 100] [--episodes 100] [--reps 10000]
      [--format table|latex|csv|json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mgrao_core import PAPER_SYSTEMS, final_utilities, make_spec, run_experiment  # noqa: E402
from mgrao_core.algorithms.oracle import bound_caveats  # noqa: E402
from mgrao_core.statistics.comparison import compare  # noqa: E402
from mgrao_core.statistics.report import render  # noqa: E402
from mgrao_core.statistics.scores import World  # noqa: E402

ALGORITHMS = ["uniform", "mgrao-1:1", "mgrao-max", "oracle", "independent-q", "bandit"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--reps", type=int, default=10_000)
    parser.add_argument("--format", default="table", choices=["table", "latex", "csv", "json"])
    args = parser.parse_args()
    worlds = []
    for system in PAPER_SYSTEMS:
        spec = make_spec(system, ALGORITHMS, seeds=args.seeds, episodes=args.episodes)
        result = run_experiment(spec)
        finals = {label: dict(zip(spec.seeds, final_utilities(result.utilities(label)).tolist(), strict=True))
                  for label in ALGORITHMS}
        worlds.append(World(system, system, args.episodes, finals, bound_caveats(spec.params)))
    answer = compare(worlds, repetitions=args.reps)
    print(json.dumps(answer, indent=1) if args.format == "json" else render(answer, args.format), end="")


if __name__ == "__main__":
    main()
