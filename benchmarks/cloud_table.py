"""The ``cloud`` preset: what each learner achieves, and what the hierarchy saves, with every kind of hierarchy.

Run: ``python benchmarks/cloud_table.py [--seeds 100] [--first-seed 0] [--episodes 100] [--set KEY=VALUE ...]``.
Held-out seeds 0 to N-1 (the preset's ``task_need`` was chosen on seeds 10000 to 10007), the paper's episodes:
the preset's algorithms (uniform, mgrao-1:1, mgrao-5:1, mgrao-max, mgrao-balance, the oracle) under
``hierarchy`` none, borrow and hand-over (docs/model.md, "A cloud"). Prints, per kind and configuration, the final
utility with its 95% interval, the % from uniform of the same kind (paired seed by seed), the failure and hand-over
rates (pooled over every atomic task), and each configuration's final utility against its own without a hierarchy
(the % the hierarchy adds, paired seed by seed, with its 95% interval): the table docs/reproduction.md shows. Then
the seconds each kind took, against the preset with nothing that can fail (``task_need`` 0), in the same process.
"""

from __future__ import annotations

import argparse
import json
import time

from mgrao_core import make_spec, run_experiment
from mgrao_core.params import HIERARCHIES
from mgrao_core.presets import get_preset
from mgrao_core.reproduction import PAPER_EPISODES
from mgrao_core.results import ExperimentResult
from mgrao_core.statistics.student import mean_ci95
from mgrao_core.statistics.summary import final_utilities


def _interval(mean: float, low: float, high: float, digits: int = 1) -> str:
    return f"{mean:+.{digits}f} [{low:+.{digits}f}, {high:+.{digits}f}]"


def rows(result: ExperimentResult, without: ExperimentResult | None) -> list[str]:
    """One markdown row per configuration of ``result``; ``without``: the same runs without a hierarchy."""
    summary, tasks = result.summary(), result.task_counts()
    out = []
    for label in result.spec.algorithms:
        s = summary[label]
        pct = "-" if s.pct_ci95 is None else _interval(s.pct_from_uniform, *s.pct_ci95)
        gain = "-"
        if without is not None:
            now, before = final_utilities(result.utilities(label)), final_utilities(without.utilities(label))
            gain = _interval(*mean_ci95(100.0 * (now / before - 1.0)))
        out.append(f"| {result.spec.params.hierarchy} | {label} | {s.final_mean:.3f} [{s.ci95[0]:.3f}, "
                   f"{s.ci95[1]:.3f}] | {pct} | {100 * tasks[label].failure_rate:.1f} | "
                   f"{100 * tasks[label].handover_rate:.1f} | {gain} |")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--episodes", type=int, default=PAPER_EPISODES)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a parameter for every run (task_need=0.5, say)")
    args = parser.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    settings = {key: json.loads(value) for key, value in (item.split("=", 1) for item in args.set)}
    algorithms = list(get_preset("cloud").algorithms)

    def run(overrides: dict) -> tuple[ExperimentResult, float]:
        overrides = {**settings, **overrides}
        spec = make_spec("cloud", algorithms, seeds=seeds, episodes=args.episodes, overrides=overrides)
        run_experiment(make_spec("cloud", algorithms, seeds=seeds[:1], episodes=2, overrides=overrides))
        started = time.perf_counter()  # (after a first small run: the kernel is compiled, or loaded, outside the time)
        return run_experiment(spec), time.perf_counter() - started

    results = {kind: run({"hierarchy": kind}) for kind in HIERARCHIES}
    described = json.dumps(settings) if settings else "the preset"
    print(f"cloud: seeds {seeds[0]}-{seeds[-1]}, {args.episodes} episodes, {described}\n")
    print("| hierarchy | configuration | final utility [95% CI] | % from uniform [95% CI] | % failed | "
          "% through a neighbour | % from no hierarchy [95% CI] |")
    print("|---|---|---|---|---|---|---|")
    for kind in HIERARCHIES:
        for row in rows(results[kind][0], None if kind == "none" else results["none"][0]):
            print(row)
    _, plain = run({"task_need": 0.0, "hierarchy": "none"})
    print(f"\nseconds (the whole table's runs of each kind, compiled): nothing can fail {plain:.2f}; " + "; ".join(
        f"{kind} {seconds:.2f} ({seconds / plain:.2f}x)" for kind, (_, seconds) in results.items()))


if __name__ == "__main__":
    main()
