"""Choose the standard learners' defaults: a sweep of their parameters on calibration seeds.

Run: ``python benchmarks/calibrate_learners.py`` (a minute or two on 2 cores; ``--seeds 30`` for a
quicker look, ``--json FILE`` to keep every number).

``independent-q`` has ``q_learning_rate`` and ``q_temperature``, ``bandit`` has ``bandit_step``;
the issue asks for defaults chosen "by a documented sweep on calibration seeds, as the
environment's were" (``benchmarks/calibrate.py``). The rules:

* the learners are baselines, so each gets the setting that serves it best: the objective is the
  mean over the paper's four systems of its % from uniform after 100 episodes (mean of the last 10
  episodes, paired by seed with uniform, as ``mgrao reproduce`` computes it);
* measured on *calibration seeds* (1000 .. 1099 by default), never on the held-out seeds 0 .. 99
  that docs/algorithms.md's results table uses;
* over a grid of round values (a finer fit between them would be a fit to the seeds' noise); the
  best mean is taken as it is, and the settings within :data:`TIE` points of it are listed, so that
  the table shows how flat the optimum is.

Every figure of the grid is printed, per system, with the mean; docs/algorithms.md ("Defaults of
the standard learners") keeps the table.
"""

from __future__ import annotations

import argparse
import itertools
import json
import time

from mgrao_core import make_spec, run_experiment

CALIBRATION_FIRST_SEED = 1_000
SYSTEMS = ("single", "multi", "volatile", "large")
Q_LEARNING_RATES = (0.0003, 0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0)
Q_TEMPERATURES = (0.001, 0.003, 0.01, 0.02, 0.03, 0.05, 0.1, 0.3)
BANDIT_STEPS = (0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0)
TIE = 0.5
"""Points of the mean within which two settings are reported as equally good."""


def figures(label: str, overrides: dict, seeds: list[int], systems: tuple[str, ...]) -> dict[str, float]:
    """``label``'s % from uniform in each system under ``overrides``, and their mean."""
    out = {}
    for system in systems:
        spec = make_spec(system, ["uniform", label], seeds=seeds, episodes=100, overrides=overrides)
        out[system] = run_experiment(spec).summary()[label].pct_from_uniform
    out["mean"] = sum(out[s] for s in systems) / len(systems)
    return out


def sweep(label: str, grid: list[dict], seeds: list[int], systems: tuple[str, ...]) -> list[dict]:
    """Every setting of ``grid`` for ``label``, printed as it comes, best mean marked at the end."""
    names = list(grid[0])
    header = "  ".join(f"{n:>15}" for n in names) + "".join(f"{s:>10}" for s in systems) + f"{'mean':>10}"
    print(header)
    rows = []
    for overrides in grid:
        row = {"overrides": overrides, "figures": figures(label, overrides, seeds, systems)}
        rows.append(row)
        print("  ".join(f"{overrides[n]:>15g}" for n in names)
              + "".join(f"{row['figures'][s]:>+10.2f}" for s in (*systems, "mean")), flush=True)
    best = max(rows, key=lambda r: r["figures"]["mean"])
    ties = [r for r in rows if best["figures"]["mean"] - r["figures"]["mean"] <= TIE and r is not best]
    shown = ", ".join(f"{k} = {v:g}" for k, v in best["overrides"].items())
    print(f"best: {shown} (mean {best['figures']['mean']:+.2f})")
    if ties:
        print(f"within {TIE} points of it: "
              + "; ".join(", ".join(f"{k} = {v:g}" for k, v in r["overrides"].items()) for r in ties))
    return rows


def main() -> None:
    """Sweep both learners and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100, help="calibration seeds (from --first-seed)")
    parser.add_argument("--first-seed", type=int, default=CALIBRATION_FIRST_SEED)
    parser.add_argument("--systems", default=",".join(SYSTEMS), help="comma-separated presets")
    parser.add_argument("--json", help="write every number to this file")
    args = parser.parse_args()
    if args.first_seed < 100:
        parser.error("seeds 0 .. 99 are held out for the results table: calibrate on others")
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    systems = tuple(args.systems.split(","))
    run_experiment(make_spec("multi", ["independent-q", "bandit"], seeds=1, episodes=2))  # load the kernel
    started = time.perf_counter()
    print(f"% from uniform after 100 episodes, seeds {seeds[0]}..{seeds[-1]}\n")
    print("independent-q")
    q_grid = [{"q_learning_rate": a, "q_temperature": t} for a, t in itertools.product(Q_LEARNING_RATES,
                                                                                        Q_TEMPERATURES)]
    report = {"seeds": [seeds[0], seeds[-1]], "systems": systems,
              "independent-q": sweep("independent-q", q_grid, seeds, systems)}
    print("\nbandit")
    report["bandit"] = sweep("bandit", [{"bandit_step": s} for s in BANDIT_STEPS], seeds, systems)
    print(f"\n{time.perf_counter() - started:.0f} s")
    if args.json:
        with open(args.json, "w") as out:
            json.dump(report, out, indent=2)


if __name__ == "__main__":
    main()
