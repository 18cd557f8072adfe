"""A lab's database: many finished jobs of realistic shapes, bulk-inserted (issue 46, item 2). Not a test.

    python benchmarks/lab_database.py URL [--jobs 100000] [--seed 46]

:func:`seed_lab` stores, through the backend's tables (bulk ``INSERT``s of a few thousand rows, one
transaction per slice of jobs), ``jobs`` jobs made of real runs:

* **Templates**: a few dozen experiments really run in this process (:func:`templates`), of the
  presets single, multi, volatile, drift, multi-resource and large, with 2 to 7 configurations, 3
  to 10 seeds, 50 to 300 episodes and a few learning rates, plus five paper-sized ones (large, 7
  configurations x 30 seeds x 1,000 episodes); each template's runs are stored as a worker stores
  them (:func:`backend.store.queue.run_rows`) and its summaries as the finish computes them.
* **Jobs** (by ``i``, drawn with ``seed``): 62% built-in jobs of a template, 8% external runs (one
  label, a template's runs of one configuration, 1 in 10 still open), 30% studies' trials (studies of
  40 to 200 trials on single, their trials' rows, their jobs named and tagged as a study names them);
  of the built-in jobs 86% succeeded, 7% failed, 5% cancelled (failed and cancelled with a part of
  their runs and no summaries), 2% queued; tags from a pool of 40 (0 to 3 a job), notes on one job
  in three, names of a few words; created over two years. Paper-sized jobs are 1 in 500.

A succeeded job's runs and summaries are its template's (the same numbers under another id): the
list, sorts and compare read them as they read any. Prints the time taken and what was stored.
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from dataclasses import dataclass
from datetime import timedelta
from pathlib import Path
from typing import Any

from sqlalchemy import insert

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import mgrao_core  # noqa: E402
from backend.store import crud, queue, summaries  # noqa: E402
from backend.store.db import Database  # noqa: E402
from backend.store.models import (  # noqa: E402
    EXTERNAL,
    SIMULATION,
    ExternalRun,
    Job,
    JobSummary,
    JobTag,
    Run,
    Study,
    Trial,
    utcnow,
)
from mgrao_core import make_spec, run_experiment  # noqa: E402

SLICE = 2000
"""Jobs per transaction."""
WORDS = ("baseline sweep ablation paper rerun check figure draft long short warm cold dense sparse fast slow "
         "noisy clean tuned default quick final trial probe replicate retry mixed edge grid tpe random").split()
TAGS = [*("paper", "sweep", "baseline", "ablation", "draft", "figure-3", "figure-5", "appendix", "rerun", "thesis"),
        *(f"student-{n}" for n in ("ana", "ben", "chen", "dara", "eli", "femi", "gus", "hana")),
        *(f"2025-q{q}" for q in range(1, 5)), *(f"2026-q{q}" for q in range(1, 5)),
        *(f"lr-{x}" for x in ("0.01", "0.05", "0.1", "0.2", "0.5")), *("cluster", "laptop", "dask", "nightly",
                                                                      "regression", "ci", "demo", "review", "keep")]
EXTERNAL_LABELS = ("ppo-baseline", "dqn-small", "greedy-heuristic", "ippo", "mappo")


@dataclass
class Template:
    """A real experiment: its stored configuration, its run rows (``job_id`` left out) and summary rows."""

    system: str
    config: dict[str, Any]
    runs: list[dict[str, Any]]
    summaries: list[dict[str, Any]]


def _template(system: str, algorithms: list[str] | None, seeds: int, episodes: int,
              params: dict[str, Any] | None = None) -> Template:
    spec = make_spec(system, algorithms, seeds, episodes, params or {})
    result = run_experiment(spec)
    rows = [{k: v for k, v in row.items() if k != "job_id"} for row in queue.run_rows(0, result.runs)]
    config = crud.job_config(spec, None)
    computed = mgrao_core.summarise(summaries.in_seed_order(summaries.finals_of_rows(rows), config["seeds"]))
    summary_rows = [{k: v for k, v in row.items() if k != "job_id"}
                    for row in summaries.summary_rows(0, computed, summaries.task_counts_of_rows(rows))]
    return Template(system, config, rows, summary_rows)


def templates(rng: random.Random) -> tuple[list[Template], list[Template], list[Template]]:
    """The built-in jobs' templates, the study trials' (single, learning rate x trace decay) and the paper-sized."""
    built_in = []
    for system, algorithms in (("single", None), ("single", ["uniform", "mgrao-max"]), ("multi", None),
                               ("volatile", None), ("drift", None), ("multi-resource", None),
                               ("large", ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max"]), ("large", None)):
        for learning_rate in (0.05, 0.1, 0.2):
            built_in.append(_template(system, algorithms, rng.choice([3, 5, 10]), rng.choice([50, 100, 200, 300]),
                                      {"learning_rate": learning_rate}))
    trials = [_template("single", ["uniform", "mgrao-max"], 3, 100,
                        {"learning_rate": lr, "trace_decay": decay})
              for lr in (0.02, 0.05, 0.1, 0.2, 0.4) for decay in (0.5, 0.7, 0.9)]
    paper = [_template("large", None, 30, 1000, {"learning_rate": lr}) for lr in (0.05, 0.1)]
    return built_in, trials, paper


def _text(rng: random.Random, low: int, high: int) -> str:
    return " ".join(rng.choice(WORDS) for _ in range(rng.randint(low, high)))


def seed_lab(url: str, jobs: int = 100_000, seed: int = 46, log=print) -> dict[str, Any]:
    """Store ``jobs`` finished jobs of realistic shapes in the (migrated) database at ``url``; what was stored.

    Returns counts (jobs by kind and status, runs, summaries, tags, studies, trials, utilities) and the seconds
    the templates and the inserts took.
    """
    rng = random.Random(seed)
    t0 = time.perf_counter()
    built_in, trial_templates, paper = templates(rng)
    made = time.perf_counter() - t0
    log(f"{len(built_in) + len(trial_templates) + len(paper)} templates run in {made:.1f} s")
    db = Database(url)
    db.migrate()
    start = utcnow() - timedelta(days=730)
    step = timedelta(days=730) / jobs
    counts: dict[str, Any] = {"jobs": 0, "runs": 0, "summaries": 0, "tags": 0, "studies": 0, "trials": 0,
                              "utilities": 0, "by_kind": {}, "by_status": {}}
    study_left = 0  # trials still to make in the current study
    study_id = trial_number = None
    t1 = time.perf_counter()
    for first in range(0, jobs, SLICE):
        with db.write() as session:
            job_rows, tag_lists, run_sources, externals, trial_rows = [], [], [], [], []
            for i in range(first, min(first + SLICE, jobs)):
                created = start + step * i
                draw = rng.random()
                status, template, kind = "succeeded", None, SIMULATION
                study = trial = None
                if draw < 0.30:  # a study's trial
                    if study_left == 0:
                        study_left = rng.randint(40, 200)
                        name = f"{rng.choice(WORDS)} {rng.choice(WORDS)} study"
                        study_id = session.scalars(insert(Study).returning(Study.id), [{
                            "name": name, "method": rng.choice(["grid", "random", "tpe"]),
                            "definition": {"name": name, "note": "seeded by benchmarks/lab_database.py"},
                            "status": "finished", "planned": study_left, "revision": study_left,
                            "version": mgrao_core.__version__, "created_at": created, "finished_at": created}]).one()
                        study_name, trial_number = name, 0
                        counts["studies"] += 1
                    study_left -= 1
                    trial_number += 1
                    template = rng.choice(trial_templates)
                    study = study_id
                    trial_rows.append({"study_id": study_id, "number": trial_number,
                                       "params": {k: template.config["params"][k] for k in ("learning_rate",
                                                                                           "trace_decay")},
                                       "status": "succeeded", "runs": len(template.runs), "created_at": created,
                                       "finished_at": created})
                    name, tags, notes = f"{study_name} #{trial_number}", [f"study-{study_id}"], ""
                    trial = len(trial_rows) - 1
                else:
                    template = paper[i % 2] if i % 500 == 7 else rng.choice(built_in)
                    name = f"{template.system} {_text(rng, 1, 3)} {i}"
                    tags = rng.sample(TAGS, rng.choice([0, 1, 1, 2, 2, 3]))
                    notes = "" if i % 3 else _text(rng, 3, 12)
                    if draw < 0.38:
                        kind = EXTERNAL
                        status = "open" if rng.random() < 0.1 else "succeeded"
                    else:
                        status = rng.choices(["succeeded", "failed", "cancelled", "queued"], [86, 7, 5, 2])[0]
                config = template.config
                runs, stored_summaries = template.runs, template.summaries
                if kind == EXTERNAL:
                    label = rng.choice(EXTERNAL_LABELS)
                    algorithm = config["algorithms"][-1]
                    config = {"system": config["system"], "params": config["params"], "algorithms": [label],
                              "seeds": config["seeds"], "episodes": config["episodes"]}
                    runs = [r | {"algorithm": label, "combined_weights": b"", "group_weights": b"",
                                 "weights_meta": None, "child_means": None, "membership": None,
                                 "membership_meta": None, "tasks_allocated": 0, "tasks_failed": 0,
                                 "tasks_handed_over": 0}
                            for r in template.runs if r["algorithm"] == algorithm]
                    stored_summaries = [s | {"algorithm": label, "pct_from_uniform": None, "pct_low": None,
                                             "pct_high": None, "pct_of_max": None, "n_paired": 0, "n_paired_max": 0,
                                             "tasks_allocated": 0, "tasks_failed": 0, "tasks_handed_over": 0}
                                        for s in template.summaries if s["algorithm"] == algorithm]
                    if status == "open":
                        runs, stored_summaries = runs[: len(runs) // 2], []
                elif status in ("failed", "cancelled"):
                    runs, stored_summaries = runs[: rng.randint(0, len(runs) // 2)], []
                elif status == "queued":
                    runs, stored_summaries = [], []
                finished = status in ("succeeded", "failed", "cancelled")
                job_rows.append({
                    "name": name, "tags": tags, "notes": notes, "system": config["system"], "config": config,
                    "config_hash": crud.config_hash(config), "status": status,
                    "progress": 1.0 if status == "succeeded" else (0.0 if status == "queued" else 0.5),
                    "attempts": 0 if status == "queued" else 1,
                    "error": "RuntimeError: the worker ran out of memory" if status == "failed" else None,
                    "version": mgrao_core.__version__, "created_at": created,
                    "started_at": None if status == "queued" else created + timedelta(seconds=2),
                    "finished_at": created + timedelta(seconds=rng.uniform(3, 600)) if finished else None,
                    "study_id": study, "trial_id": None, "kind": kind,
                    "work": None if kind == EXTERNAL else 1})
                tag_lists.append(tags)
                run_sources.append((runs, stored_summaries, trial))
                if kind == EXTERNAL:
                    externals.append(len(job_rows) - 1)
            trial_ids = (list(session.scalars(insert(Trial).returning(Trial.id, sort_by_parameter_order=True),
                                              trial_rows)) if trial_rows else [])
            for row, (_, _, trial) in zip(job_rows, run_sources, strict=True):
                if trial is not None:
                    row["trial_id"] = trial_ids[trial]
            ids = list(session.scalars(insert(Job).returning(Job.id, sort_by_parameter_order=True), job_rows))
            tag_rows = [{"job_id": job_id, "tag": t} for job_id, tags in zip(ids, tag_lists, strict=True)
                        for t in tags]
            if tag_rows:
                session.execute(insert(JobTag), tag_rows)
            crud.add_search_rows(session, [(job_id, row["name"], row["notes"], row["tags"])
                                           for job_id, row in zip(ids, job_rows, strict=True)])
            if externals:
                session.execute(insert(ExternalRun), [{"job_id": ids[k], "open_key": None,
                                                       "definition_digest": "0" * 64} for k in externals])
            run_rows, summary_rows = [], []
            for job_id, (runs, stored_summaries, _) in zip(ids, run_sources, strict=True):
                run_rows += [r | {"job_id": job_id} for r in runs]
                summary_rows += [s | {"job_id": job_id} for s in stored_summaries]
                counts["utilities"] += sum(r["episodes"] for r in runs)
            for k in range(0, len(run_rows), 500):
                session.execute(insert(Run), run_rows[k : k + 500])
            if summary_rows:
                session.execute(insert(JobSummary), summary_rows)
            counts["jobs"] += len(ids)
            counts["runs"] += len(run_rows)
            counts["summaries"] += len(summary_rows)
            counts["tags"] += len(tag_rows)
            counts["trials"] += len(trial_rows)
            for row in job_rows:
                counts["by_kind"][row["kind"]] = counts["by_kind"].get(row["kind"], 0) + 1
                counts["by_status"][row["status"]] = counts["by_status"].get(row["status"], 0) + 1
        if (first // SLICE) % 10 == 9:
            log(f"  {counts['jobs']:,} jobs, {counts['runs']:,} runs in {time.perf_counter() - t1:.0f} s")
    db.dispose()
    counts["templates_s"], counts["insert_s"] = made, time.perf_counter() - t1
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url", help="SQLAlchemy URL of the database (migrated first)")
    parser.add_argument("--jobs", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=46)
    args = parser.parse_args()
    counts = seed_lab(args.url, args.jobs, args.seed)
    print(counts)


if __name__ == "__main__":
    main()
