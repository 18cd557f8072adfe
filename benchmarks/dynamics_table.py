"""docs/reproduction.md's tables for the systems beyond the paper: ``drift`` and ``bursty`` (issue 20, point 7).

Run: ``python benchmarks/dynamics_table.py`` (100 held-out seeds 0 .. 99, 100 episodes; under a minute on
2 cores). ``--seeds``, ``--first-seed``, ``--json FILE``.

Three tables, every interval a 95% t-interval over the seeds, every comparison paired by seed (common
random numbers: every algorithm of a seed faces the same world and the same events):

1. **Every algorithm against uniform** on ``drift`` (uniform, mgrao-1:1, mgrao-5:1, mgrao-max, oracle) and
   ``bursty`` (its preset's configurations and the oracle): % from uniform after 100 episodes (mean of
   the last 10), exactly as ``mgrao run`` computes it (:func:`mgrao_core.statistics.summary.summarise`), and % of max.
2. **Recovery after drift** (``drift``: at the start of episode 50, 30% of the parents draw new value
   profiles). Per seed and algorithm, the % from uniform of the mean utility over a window of episodes
   (both means over the same window): 40-49 (before), 50-54 and 55-59 (just after), 60-69, 90-99. Then
   the episodes to recover: the first ``r >= 0`` such that the mean utility of episodes ``50 + r`` to
   ``50 + r + 4`` reaches 95% (and 99%) of the mean of episodes 40-49, per seed; a seed that never does
   within the run counts as not recovered and is left out of the mean (its count is printed). Uniform's
   expected utility does not depend on the value profiles (every type gets the same quality), so its
   level is the reference the others fall from. The oracle is the best fixed allocation for the
   *initial* world (docs/model.md, "The oracle's expected values"): it cannot recover, by construction.
3. **Does algorithm 2's count term help?** ``group_blend`` = ``dkl-and-count`` (the paper's
   ``B = sumnorm(dkl) + sumnorm(count)``, the default) against ``dkl-only`` (``B = sumnorm(dkl)``), on
   ``bursty`` (half the composite types every 4th episode: the groups' sample counts differ) and on
   ``large`` (every type every episode: the counts of equal groups are equal) for contrast. Per
   configuration, % from uniform under each, after 100 episodes (last 10) and over all 100 episodes
   (the mean utility of the whole run, which weighs early learning), and the paired difference
   dkl-only minus dkl-and-count (positive: dropping the counts helps). mgrao-1:1 is left out: with one
   group the blend is moot and both give the same numbers.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from mgrao_core import PRESETS, make_spec, run_experiment
from mgrao_core.statistics.student import mean_ci95

DRIFT_ALGORITHMS = ("uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max", "oracle")
DRIFT_EPISODE = 50
DRIFT_FRACTIONS = (0.3, 1.0)
WINDOWS = ((40, 50), (50, 55), (55, 60), (60, 70), (90, 100))
RECOVERY_WINDOW = 5
RECOVERY_LEVELS = (0.95, 0.99)
BLEND_SYSTEMS = ("bursty", "large")


def fmt(mean: float, low: float, high: float, digits: int = 1) -> str:
    """``mean [low, high]`` with signs."""
    return f"{mean:+.{digits}f} [{low:+.{digits}f}, {high:+.{digits}f}]"


def pct_over(result, algorithm: str, start: int = -10, stop: int | None = None) -> np.ndarray:
    """Per seed, 100 * (mean utility over episodes start..stop-1 / uniform's over the same - 1)."""
    mine = result.utilities(algorithm)[:, start:stop].mean(axis=1)
    base = result.utilities("uniform")[:, start:stop].mean(axis=1)
    return 100.0 * (mine / base - 1.0)


def versus_uniform(system: str, algorithms: tuple[str, ...], seeds: list[int], episodes: int) -> tuple[object, list]:
    """Table 1's rows for ``system``, and the result."""
    result = run_experiment(make_spec(system, list(algorithms), seeds=seeds, episodes=episodes))
    summary = result.summary()
    rows = []
    for label in algorithms:
        if label == "uniform":
            continue
        s = summary[label]
        rows.append({"system": system, "algorithm": label, "pct": s.pct_from_uniform, "ci95": list(s.pct_ci95),
                     "pct_of_max": s.pct_of_max})
    u_mean, u_low, u_high = mean_ci95(result.utilities("uniform")[:, -10:].mean(axis=1))
    rows.append({"system": system, "algorithm": "uniform (utility)", "pct": u_mean, "ci95": [u_low, u_high],
                 "pct_of_max": None})
    return result, rows


def lag_closed(lag: np.ndarray, share: float) -> np.ndarray:
    """Per seed, the first ``r`` after which ``lag[:, r:]`` stays at or below ``(1 - share)`` of ``lag[:, 0]``.

    ``lag`` is ``(seeds, episodes after the drift)``; a seed with no initial lag has recovered at 0, and a seed
    whose lag is still above the bound at the run's end gets NaN.
    """
    bound = (1.0 - share) * np.maximum(lag[:, :1], 0.0)
    above = lag > bound
    out = np.zeros(lag.shape[0])
    for i, row in enumerate(above):
        where = np.flatnonzero(row)
        out[i] = 0.0 if where.size == 0 else (np.nan if where[-1] == row.size - 1 else where[-1] + 1.0)
    return out


def recovery(system: str, fraction: float, seeds: list[int], episodes: int) -> tuple[list, list]:
    """Table 2: gains per window and episodes to recover, per algorithm, for a drift of ``fraction`` of the parents.

    Three runs of the same seeds: the drift at episode 50, none, and the drift at episode 0 (the *new world*
    from the start: the event's draws do not depend on its episode). From episode 50 on, the drifted and the
    new-world runs face the same world and the same draws; what separates them is only what the learner
    learned before the drift. The lag is the new-world run's utility minus the drifted run's, per episode.
    """
    def run(schedule):
        return run_experiment(make_spec(system, list(DRIFT_ALGORITHMS), seeds=seeds, episodes=episodes,
                                        overrides={"schedule": schedule}))

    drifted = run([{"episode": DRIFT_EPISODE, "change": "new-profiles", "fraction": fraction}])
    steady = run([])
    fresh = run([{"episode": 0, "change": "new-profiles", "fraction": fraction}])
    uniform = drifted.utilities("uniform")
    windows, recover = [], []
    for label in drifted.spec.algorithms:
        if label == "uniform":
            continue
        cells = {name: [list(mean_ci95(pct_over(r, label, a, b))) for a, b in WINDOWS if b <= episodes]
                 for name, r in (("drift", drifted), ("no drift", steady), ("new world", fresh))}
        windows.append({"algorithm": label, "fraction": fraction, "windows": cells})
        u = drifted.utilities(label)
        before = u[:, DRIFT_EPISODE - 10:DRIFT_EPISODE].mean(axis=1)
        after = u[:, DRIFT_EPISODE:]
        rolling = np.stack([after[:, r:r + RECOVERY_WINDOW].mean(axis=1)
                            for r in range(after.shape[1] - RECOVERY_WINDOW + 1)], axis=1)
        reached = rolling >= 0.95 * before[:, None]
        lag = 100.0 * (fresh.utilities(label)[:, DRIFT_EPISODE:] - after) / uniform[:, DRIFT_EPISODE:]
        row = {"algorithm": label, "fraction": fraction,
               "drop": list(mean_ci95(100.0 * (after[:, :RECOVERY_WINDOW].mean(axis=1) / before - 1.0))),
               "to_95_of_before": {"recovered": int(reached.any(axis=1).sum()), "seeds": len(seeds),
                                   "episodes": list(mean_ci95(np.argmax(reached, axis=1)[reached.any(axis=1)]))},
               "lag_at_drift": list(mean_ci95(lag[:, 0])), "lag": {}}
        for share in RECOVERY_LEVELS:
            closed = lag_closed(lag, share)
            ok = ~np.isnan(closed)
            row["lag"][share] = {"recovered": int(ok.sum()), "seeds": len(seeds),
                                 "episodes": list(mean_ci95(closed[ok])) if ok.any() else None,
                                 "median": float(np.median(closed[ok])) if ok.any() else None}
        recover.append(row)
    return windows, recover


def blend(system: str, seeds: list[int], episodes: int) -> list:
    """Table 3's rows for ``system``: each configuration under both blends, and the paired difference."""
    algorithms = [a for a in PRESETS[system].algorithms if a not in ("uniform", "mgrao-1:1")]
    results = {b: run_experiment(make_spec(system, ["uniform", *algorithms], seeds=seeds, episodes=episodes,
                                           overrides={"group_blend": b}))
               for b in ("dkl-and-count", "dkl-only")}
    rows = []
    for label in algorithms:
        row = {"system": system, "algorithm": label}
        for span, start in (("final", -10), ("whole", 0)):
            both = {b: pct_over(r, label, start) for b, r in results.items()}
            row[span] = {b: list(mean_ci95(v)) for b, v in both.items()}
            row[span]["difference"] = list(mean_ci95(both["dkl-only"] - both["dkl-and-count"]))
        rows.append(row)
    return rows


def main() -> None:
    """Run the three tables and print them as Markdown."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--json", help="write every number to this file")
    args = parser.parse_args()
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    episodes = 100
    started = time.perf_counter()
    _, drift_rows = versus_uniform("drift", DRIFT_ALGORITHMS, seeds, episodes)
    bursty_algorithms = (*PRESETS["bursty"].algorithms, "oracle")
    _, bursty_rows = versus_uniform("bursty", bursty_algorithms, seeds, episodes)
    windows, recover = [], []
    for fraction in DRIFT_FRACTIONS:
        more_windows, more_recover = recovery("drift", fraction, seeds, episodes)
        windows += more_windows
        recover += more_recover
    blend_rows = [row for system in BLEND_SYSTEMS for row in blend(system, seeds, episodes)]
    elapsed = time.perf_counter() - started

    print(f"Seeds {seeds[0]}..{seeds[-1]}, {episodes} episodes; mean [95% CI] over seeds, paired by seed.\n")
    print("Table 1. % from uniform after 100 episodes (mean of the last 10)\n")
    print("| system | algorithm | % from uniform [95% CI] | % of max |")
    print("| --- | --- | --- | ---: |")
    for r in drift_rows + bursty_rows:
        if r["pct_of_max"] is None:
            print(f"| {r['system']} | uniform's utility | {r['pct']:.3f} [{r['ci95'][0]:.3f}, {r['ci95'][1]:.3f}] | |")
        else:
            print(f"| {r['system']} | {r['algorithm']} | {fmt(r['pct'], *r['ci95'])} | {r['pct_of_max']:.1f} |")

    print(f"\nTable 2. drift: % from uniform over windows of episodes; at the start of episode {DRIFT_EPISODE} a "
          "share of the parents draw new value profiles (0.3: the preset; 1: every parent, for contrast). "
          "'no drift': the same seeds without the event; 'new world': with it at episode 0\n")
    heads = [f"{a}-{b - 1}" for a, b in WINDOWS if b <= episodes]
    print("| share | algorithm | " + " | ".join(heads) + f" | no drift {heads[-1]} | new world {heads[-1]} |")
    print("| --- | --- |" + " --- |" * (len(heads) + 2))
    for w in windows:
        cells = [fmt(*c) for c in w["windows"]["drift"]]
        cells += [fmt(*w["windows"]["no drift"][-1]), fmt(*w["windows"]["new world"][-1])]
        print(f"| {w['fraction']:g} | {w['algorithm']} | " + " | ".join(cells) + " |")
    print("\nRecovery. 'drop': utility of episodes 50-54 against 40-49 (%). 'to 95% of before': episodes until "
          f"the mean utility of {RECOVERY_WINDOW} episodes reaches 95% of episodes 40-49's. 'lag': the new-world "
          "run's utility minus the drifted run's, in % of uniform's (same world and draws from episode 50 on), "
          "at episode 50; then the episodes until it stays within 5% (1%) of that initial lag\n")
    print("| share | algorithm | drop (%) | to 95% of before | lag at 50 (points) | lag 95% closed: mean [CI] "
          "| median | seeds | 99% closed: mean [CI] | median | seeds |")
    print("| --- | --- | --- | --- | --- | --- | ---: | ---: | --- | ---: | ---: |")
    for r in recover:
        literal = r["to_95_of_before"]
        cells = [fmt(*r["drop"]), f"{literal['episodes'][0]:.1f} ({literal['recovered']}/{literal['seeds']})",
                 fmt(*r["lag_at_drift"], digits=2)]
        for share in RECOVERY_LEVELS:
            v = r["lag"][share]
            if v["episodes"] is None:
                cells += ["never", "", f"0/{v['seeds']}"]
            else:
                m, lo, hi = v["episodes"]
                ci = "" if np.isnan(lo) else f" [{lo:.1f}, {hi:.1f}]"
                cells += [f"{m:.1f}{ci}", f"{v['median']:.0f}", f"{v['recovered']}/{v['seeds']}"]
        print(f"| {r['fraction']:g} | {r['algorithm']} | " + " | ".join(cells) + " |")

    print("\nTable 3. group_blend: % from uniform with the paper's blend (dkl-and-count) and without the "
          "counts (dkl-only); difference dkl-only minus dkl-and-count, paired by seed (points)\n")
    print("| system | algorithm | last 10: dkl-and-count | dkl-only | difference | "
          "all 100: dkl-and-count | dkl-only | difference |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in blend_rows:
        cells = []
        for span in ("final", "whole"):
            cells += [fmt(*r[span]["dkl-and-count"]), fmt(*r[span]["dkl-only"]),
                      fmt(*r[span]["difference"], digits=2)]
        print(f"| {r['system']} | {r['algorithm']} | " + " | ".join(cells) + " |")
    print(f"\nsimulation {elapsed:.0f} s")
    if args.json:
        with open(args.json, "w") as out:
            json.dump({"seeds": [seeds[0], seeds[-1]], "versus_uniform": drift_rows + bursty_rows,
                       "drift_windows": windows, "drift_recovery": recover, "blend": blend_rows},
                      out, indent=2, default=str)


if __name__ == "__main__":
    main()
