"""The study the paper did not run: what parent groups save and cost, from the paper's size to 110,000 agents.

    python benchmarks/scale_study.py [--seeds 20] [--big-seeds 5] [--episodes 100] [--out docs/img]

Sparse worlds on a ring (docs/model.md, "Sparse worlds"): each parent offers its tasks to its 8 nearest children, and
there are ten parents a child, from 100 parents and 10 children to 100,000 parents and 10,000 children. At each size
every learner runs on the same seeds as uniform (common random numbers): ``mgrao-1:1``, ``mgrao-10:1``,
``mgrao-100:1`` and ``mgrao-max`` while it fits the memory budget (2 GiB per chunk; the check of
``mgrao_core.make_spec`` says where it stops). Printed and drawn (``--out``):

* each learner's gain over uniform (% from uniform, mean over seeds with its 95% t-interval, docs/statistics.md),
  and where ``mgrao-max`` runs, each group count's paired difference from it (mean and 95% t-interval);
* each learner's state per child (bytes: what the budget counts of its lanes, per child);
* the kernel's time per episode of uniform and of ``mgrao-100:1`` at each size (benchmarks/bench_scale.py's method).

Seeds: ``--seeds`` at every size but the largest, which takes ``--big-seeds`` (each of its runs takes several
seconds). The figures of docs/scale.md come from the defaults.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import numpy as np  # noqa: E402
from bench_scale import kernel_seconds  # noqa: E402

from mgrao_core import WorkLimitError, make_spec, run_experiment  # noqa: E402
from mgrao_core.statistics.student import mean_ci95  # noqa: E402
from mgrao_core.statistics.summary import final_utilities  # noqa: E402

SIZES = (100, 1_000, 10_000, 100_000)
"""Parents at each size; children are a tenth of them."""
GROUPS = ("mgrao-1:1", "mgrao-10:1", "mgrao-100:1")
MAX = "mgrao-max"


def overrides(parents: int) -> dict:
    return {"n_parents": parents, "n_children": parents // 10, "topology": "ring", "children_per_parent": 8}


def learners(parents: int) -> list[str]:
    """The group counts that divide the parents, and mgrao-max where one seed of it fits the budget."""
    labels = [label for label in GROUPS if parents % int(label.split("-")[1].split(":")[0]) == 0]
    try:
        make_spec("multi", ["uniform", MAX], [0], 100, overrides(parents))
        labels.append(MAX)
    except WorkLimitError as error:
        print(f"  {MAX} at {parents:,} parents: refused ({error.field}): {error.message}")
    return labels


def per_child_bytes(parents: int, label: str) -> int:
    """A child's learner state in bytes, as the registry gives it (``Family.memory_per_child``: nothing allocated)."""
    from mgrao_core.algorithms import family_of, parse_algorithm

    params = make_spec("multi", ["uniform"], [0], 1, overrides(parents)).params
    algorithm = parse_algorithm(label, params.n_parents)
    return family_of(algorithm).memory_per_child(algorithm, params)


def study(parents: int, seeds: int, episodes: int) -> dict:
    labels = ["uniform", *learners(parents)]
    began = time.perf_counter()
    result = run_experiment(make_spec("multi", labels, list(range(seeds)), episodes, overrides(parents)))
    finals = {label: final_utilities(result.utilities(label)) for label in labels}
    pct = {label: 100.0 * (finals[label] / finals["uniform"] - 1.0) for label in labels[1:]}
    answer = {"labels": labels[1:], "gain": {label: mean_ci95(pct[label]) for label in labels[1:]},
              "seconds": time.perf_counter() - began}
    if MAX in pct:
        answer["from_max"] = {label: mean_ci95(pct[label] - pct[MAX]) for label in labels[1:] if label != MAX}
    return answer


def draw(results: dict, memory: dict, times: dict, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    colours = {"mgrao-1:1": "#1f77b4", "mgrao-10:1": "#2ca02c", "mgrao-100:1": "#9467bd", MAX: "#d62728"}
    agents = {p: p + p // 10 for p in results}
    figure, axis = plt.subplots(figsize=(7, 4.2))
    for label, colour in colours.items():
        xs = [agents[p] for p in results if label in results[p]["gain"]]
        if not xs:
            continue
        mean = np.array([results[p]["gain"][label][0] for p in results if label in results[p]["gain"]])
        low = np.array([results[p]["gain"][label][1] for p in results if label in results[p]["gain"]])
        high = np.array([results[p]["gain"][label][2] for p in results if label in results[p]["gain"]])
        axis.errorbar(xs, mean, yerr=[mean - low, high - mean], label=label, color=colour, marker="o", capsize=3)
    axis.set_xscale("log")
    axis.set_xlabel("agents (parents + children; ten parents a child, 8 children per parent on a ring)")
    axis.set_ylabel("% from uniform (final 10 episodes), 95% CI")
    axis.legend()
    axis.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(out / "scale-gain.png", dpi=110)
    plt.close(figure)
    figure, axis = plt.subplots(figsize=(7, 4.2))
    for label, colour in colours.items():
        xs = [agents[p] for p in memory if label in memory[p]]
        axis.plot(xs, [memory[p][label] for p in memory if label in memory[p]], marker="o", color=colour,
                  label=label)
    axis.set_xscale("log")
    axis.set_yscale("log")
    axis.set_xlabel("agents")
    axis.set_ylabel("learner state per child (bytes)")
    axis.axhline(2 * 1024**3 / 10_000, color="grey", linestyle=":", label="2 GiB over 10,000 children")
    axis.legend()
    axis.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(out / "scale-memory.png", dpi=110)
    plt.close(figure)
    figure, axis = plt.subplots(figsize=(7, 4.2))
    for label, colour in (("uniform", "#7f7f7f"), ("mgrao-100:1", colours["mgrao-100:1"])):
        axis.plot([agents[p] for p in times], [1000 * times[p][label] for p in times], marker="o", color=colour,
                  label=label)
    axis.set_xscale("log")
    axis.set_yscale("log")
    axis.set_xlabel("agents")
    axis.set_ylabel("kernel time per episode (ms)")
    axis.legend()
    axis.grid(alpha=0.3)
    figure.tight_layout()
    figure.savefig(out / "scale-time.png", dpi=110)
    plt.close(figure)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--big-seeds", type=int, default=5)
    parser.add_argument("--episodes", type=int, default=100)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    results, memory, times = {}, {}, {}
    for parents in SIZES:
        seeds = args.big_seeds if parents == SIZES[-1] else args.seeds
        print(f"{parents:,} parents, {parents // 10:,} children, {seeds} seeds, {args.episodes} episodes")
        results[parents] = study(parents, seeds, args.episodes)
        memory[parents] = {label: per_child_bytes(parents, label) for label in [*GROUPS, MAX]
                           if label == MAX or parents % int(label.split("-")[1].split(":")[0]) == 0}
        times[parents] = {label: kernel_seconds(parents, parents // 10, "ring", 6, label)
                          for label in ("uniform", "mgrao-100:1")}
        r = results[parents]
        for label in r["labels"]:
            mean, low, high = r["gain"][label]
            line = (f"  {label:12s} {mean:+6.2f}% [{low:+6.2f}, {high:+6.2f}]   state "
                    f"{memory[parents][label]:>12,.0f} B/child")
            if "from_max" in r and label in r["from_max"]:
                d, dl, dh = r["from_max"][label]
                line += f"   - {MAX}: {d:+6.2f} [{dl:+6.2f}, {dh:+6.2f}]"
            print(line)
        if MAX not in r["labels"]:
            print(f"  {MAX:12s} (not run: over the memory budget)   state {memory[parents][MAX]:>12,.0f} B/child")
        print(f"  kernel per episode: uniform {1000 * times[parents]['uniform']:.1f} ms, mgrao-100:1 "
              f"{1000 * times[parents]['mgrao-100:1']:.1f} ms; the study's runs took {r['seconds']:.0f} s")
    if args.out is not None:
        draw(results, memory, times, args.out)
        print(f"plots: {args.out}/scale-gain.png, scale-memory.png, scale-time.png")


if __name__ == "__main__":
    main()
