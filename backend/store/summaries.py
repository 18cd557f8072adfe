"""Per-configuration summaries of finished jobs, stored once (``job_summaries``) and read by listings.

A job's summary per configuration (final mean with its 95% interval, % from uniform with its
interval, % of max: :func:`mgrao_core.summarise`) is computed from its stored runs in the
transaction that marks it succeeded, so that the runs table can show and sort result columns, and
studies read their trials' objectives, without reading any run again. Beside it the configuration's
:class:`mgrao_core.TaskCounts` summed over its seeds, from which every summary the API serves carries
``failure_rate`` and ``handover_rate`` (:func:`summary_dict`; 0 where no task can fail).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from sqlalchemy import Row, delete, func, insert, select
from sqlalchemy.orm import Session

from backend.store.models import Job, JobSummary, Run
from mgrao_core import ConfigSummary, TaskCounts, final_utilities, summarise

RESULT_FIELDS = ("final_mean", "pct_from_uniform", "pct_of_max")
"""The summary values a listing can sort by."""


def finals(session: Session, job_id: int) -> dict[str, dict[int, float]]:
    """Each stored run's final utility, by algorithm and seed, in the order stored (streamed a few at a time)."""
    out: dict[str, dict[int, float]] = defaultdict(dict)
    statement = (select(Run.algorithm, Run.seed, Run.utilities).where(Run.job_id == job_id).order_by(Run.id)
                 .execution_options(yield_per=32))
    for algorithm, seed, blob in session.execute(statement):
        out[algorithm][seed] = float(final_utilities(np.frombuffer(blob, dtype="<f8"))[0])
    return dict(out)


def in_seed_order(finals: dict[str, dict[int, float]], seeds: Sequence[int]) -> dict[str, dict[int, float]]:
    """Each configuration's final utilities in the job's seed order: the order its summaries are computed in.

    A mean's last bits depend on the order of its terms, so every summary of a job, stored (:func:`compute`, a
    batch's :func:`backend.store.queue.finish_batch`, migration 0016) or computed on read (its results), takes
    its seeds in the order of its configuration's ``seeds``, and a seed it does not list (a run logged from
    outside) at the first's place, in the order stored: one interval per configuration, wherever it is shown.
    """
    order = {seed: i for i, seed in enumerate(seeds)}
    return {algorithm: dict(sorted(by_seed.items(), key=lambda item: order.get(item[0], 0)))
            for algorithm, by_seed in finals.items()}


def compute(session: Session, job_id: int) -> dict[str, ConfigSummary]:
    """The per-configuration summaries of a job's stored runs (final utilities only, in its seed order)."""
    config = session.scalar(select(Job.config).where(Job.id == job_id))
    return summarise(in_seed_order(finals(session, job_id), (config or {}).get("seeds", [])))


def finals_of_rows(rows: Iterable[dict[str, Any]]) -> dict[str, dict[int, float]]:
    """Each run's final utility, by algorithm and seed, from run rows (:func:`backend.store.queue.run_rows`).

    What :func:`compute` reads back from the stored runs, taken from the rows before they are stored
    (a batch of small jobs is summarised without reading its runs again).
    """
    finals: dict[str, dict[int, float]] = defaultdict(dict)
    for row in rows:
        finals[row["algorithm"]][row["seed"]] = float(final_utilities(np.frombuffer(row["utilities"], dtype="<f8"))[0])
    return dict(finals)


def task_counts(session: Session, job_id: int) -> dict[str, TaskCounts]:
    """Each algorithm's stored runs' :class:`~mgrao_core.TaskCounts`, summed over seeds (one aggregate query)."""
    statement = (select(Run.algorithm, func.sum(Run.tasks_allocated), func.sum(Run.tasks_failed),
                        func.sum(Run.tasks_handed_over)).where(Run.job_id == job_id).group_by(Run.algorithm))
    return {algorithm: TaskCounts(int(allocated or 0), int(failed or 0), int(handed_over or 0))
            for algorithm, allocated, failed, handed_over in session.execute(statement)}


def task_counts_of_rows(rows: Iterable[dict[str, Any]]) -> dict[str, TaskCounts]:
    """:func:`task_counts` from run rows (:func:`backend.store.queue.run_rows`) before they are stored."""
    out: dict[str, TaskCounts] = defaultdict(TaskCounts)
    for row in rows:
        out[row["algorithm"]] += TaskCounts(row["tasks_allocated"], row["tasks_failed"], row["tasks_handed_over"])
    return dict(out)


def summary_dict(summary: ConfigSummary, tasks: TaskCounts | None) -> dict[str, Any]:
    """A configuration's summary as the API serves it: the core's, with the rates of its atomic tasks.

    ``ConfigSummary.as_dict`` and ``failure_rate``, ``handover_rate`` pooled over its seeds (0.0 without counts).
    """
    return summary.as_dict() | (tasks or TaskCounts()).rates()


def _finite(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None


def _rows(job_id: int, summaries: dict[str, ConfigSummary], tasks: dict[str, TaskCounts]) -> list[dict[str, Any]]:
    rows = []
    for algorithm, s in summaries.items():
        low, high = s.ci95
        pct_low, pct_high = s.pct_ci95 if s.pct_ci95 is not None else (None, None)
        counts = tasks.get(algorithm, TaskCounts())
        rows.append({
            "job_id": job_id, "algorithm": algorithm, "n_runs": s.n_runs, "final_mean": _finite(s.final_mean),
            "final_low": _finite(low), "final_high": _finite(high), "pct_from_uniform": _finite(s.pct_from_uniform),
            "pct_low": _finite(pct_low), "pct_high": _finite(pct_high), "pct_of_max": _finite(s.pct_of_max),
            "n_paired": s.n_paired, "n_paired_max": s.n_paired_max, "tasks_allocated": counts.allocated,
            "tasks_failed": counts.failed, "tasks_handed_over": counts.handed_over,
        })
    return rows


def store(session: Session, job_id: int) -> dict[str, ConfigSummary]:
    """Compute a job's summaries (and task counts) and write them (replacing any); call inside a write transaction."""
    summaries = compute(session, job_id)
    write(session, {job_id: summaries}, {job_id: task_counts(session, job_id)})
    return summaries


def write(session: Session, by_job: dict[int, dict[str, ConfigSummary]],
          tasks: dict[int, dict[str, TaskCounts]] | None = None) -> None:
    """Write the given jobs' summaries (replacing any) in two statements; call inside a write transaction.

    ``tasks`` holds each job's task counts per configuration (:func:`task_counts`); a job or configuration it
    lacks stores 0.
    """
    if not by_job:
        return
    session.execute(delete(JobSummary).where(JobSummary.job_id.in_(list(by_job))))
    tasks = tasks or {}
    rows = [row for job_id, summaries in by_job.items() for row in _rows(job_id, summaries, tasks.get(job_id, {}))]
    if rows:
        session.execute(insert(JobSummary), rows)


def as_config_summary(row: JobSummary | Row) -> ConfigSummary:
    """A stored summary as the core's :class:`~mgrao_core.ConfigSummary` (a figure stored as NULL is NaN again)."""
    nan = float("nan")

    def number(value: float | None) -> float:
        return nan if value is None else value

    pct_ci = None if row.pct_from_uniform is None else (number(row.pct_low), number(row.pct_high))
    return ConfigSummary(algorithm=row.algorithm, n_runs=row.n_runs, final_mean=number(row.final_mean),
                         ci95=(number(row.final_low), number(row.final_high)), pct_from_uniform=row.pct_from_uniform,
                         pct_ci95=pct_ci, pct_of_max=row.pct_of_max, n_paired=row.n_paired or 0,
                         n_paired_max=row.n_paired_max or 0)


def config_summaries(session: Session, job_ids: Iterable[int]) -> dict[int, dict[str, ConfigSummary]]:
    """The stored summaries of the given jobs as the core's summaries, in one query (absent: none stored)."""
    ids = list(job_ids)
    out: dict[int, dict[str, ConfigSummary]] = defaultdict(dict)
    if ids:
        for row in session.execute(select(*JobSummary.__table__.columns).where(JobSummary.job_id.in_(ids))):
            out[row.job_id][row.algorithm] = as_config_summary(row)
    return dict(out)


def as_dict(row: JobSummary | Row) -> dict[str, Any]:
    """A stored summary, a model or a row of its columns, as the API shows it (:func:`summary_dict`).

    As there, ``pct_ci95`` is null where there is no % from uniform, and ``[null, null]`` where there is one
    without an interval (a single paired seed).
    """
    pct_ci = None if row.pct_from_uniform is None else [row.pct_low, row.pct_high]
    tasks = TaskCounts(row.tasks_allocated or 0, row.tasks_failed or 0, row.tasks_handed_over or 0)
    return {
        "algorithm": row.algorithm, "n_runs": row.n_runs, "final_mean": row.final_mean,
        "ci95": [row.final_low, row.final_high], "pct_from_uniform": row.pct_from_uniform, "pct_ci95": pct_ci,
        "pct_of_max": row.pct_of_max, "n_paired": row.n_paired, "n_paired_max": row.n_paired_max,
        "partial": None if row.n_paired is None else 0 < row.n_paired < row.n_runs,
    } | tasks.rates()


def of_jobs(session: Session, job_ids: Iterable[int]) -> dict[int, dict[str, dict[str, Any]]]:
    """The stored summaries of the given jobs: ``{job_id: {algorithm: summary}}`` (absent: none stored)."""
    ids = list(job_ids)
    out: dict[int, dict[str, dict[str, Any]]] = defaultdict(dict)
    if ids:  # rows of columns, not models: a page's 150 summaries cost no ORM objects
        for row in session.execute(select(*JobSummary.__table__.columns).where(JobSummary.job_id.in_(ids))):
            out[row.job_id][row.algorithm] = as_dict(row)
    return out
