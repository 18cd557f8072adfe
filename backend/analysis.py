"""Results and comparisons, computed from the stored episodes with the core's aggregation."""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.crud import get_job, job_dict
from backend.errors import Conflict
from backend.models import SUCCEEDED, Job, Run
from mgrao_core import PRESETS, episode_band, final_utilities, summarise
from mgrao_core.reproduction import PAPER_EPISODES


def utilities(run: Run) -> np.ndarray:
    """A run's episode utilities (float64, episode order)."""
    return np.frombuffer(run.utilities, dtype="<f8")


def _runs(session: Session, job_ids: Sequence[int]) -> list[Run]:
    return list(session.scalars(select(Run).where(Run.job_id.in_(job_ids)).order_by(Run.id)))


def require_succeeded(job: Job) -> None:
    """Raise :class:`Conflict` unless the job has succeeded (only then are its results stored)."""
    if job.status != SUCCEEDED:
        raise Conflict(f"job {job.id} is {job.status}: results exist only for succeeded jobs")


def paper_figures(job: Job) -> dict[str, float] | None:
    """The paper's "% from uniform" for the job's algorithms, if it is the paper's experiment.

    That is: the preset's parameters unchanged and the paper's 100 episodes (its tables are
    "after 100 episodes"); any other job has no published figure to stand beside.
    """
    preset = PRESETS[job.system]
    if job.config["params"] != preset.params.as_dict() or job.config["episodes"] != PAPER_EPISODES:
        return None
    figures = {a: preset.paper_pct_from_uniform[a] for a in job.config["algorithms"]
               if a in preset.paper_pct_from_uniform}
    return figures or None


def _weights(runs: list[Run]) -> dict[str, Any]:
    combined = np.mean([np.frombuffer(r.combined_weights, dtype="<f8") for r in runs], axis=0)
    shape = runs[0].group_shape
    n_children = shape[0]
    groups: list = []
    if shape and shape[1] > 0:
        groups = np.mean([np.frombuffer(r.group_weights, dtype="<f8") for r in runs], axis=0)
        groups = groups.reshape(shape).tolist()
    return {"combined": combined.reshape(n_children, -1).tolist(), "groups": groups}


def _configurations(session: Session, job: Job, points: int | None, include_seeds: bool) -> list[dict[str, Any]]:
    by_algorithm: dict[str, list[Run]] = {a: [] for a in job.config["algorithms"]}
    for run in _runs(session, [job.id]):
        by_algorithm[run.algorithm].append(run)
    seed_order = {seed: i for i, seed in enumerate(job.config["seeds"])}
    matrices: dict[str, np.ndarray] = {}
    finals: dict[str, dict[int, float]] = {}
    for algorithm, runs in by_algorithm.items():
        runs.sort(key=lambda r: seed_order[r.seed])
        matrices[algorithm] = np.stack([utilities(r) for r in runs])
        finals[algorithm] = dict(zip([r.seed for r in runs], final_utilities(matrices[algorithm]).tolist(),
                                     strict=True))
    summaries = summarise(finals)
    configurations = []
    for algorithm, runs in by_algorithm.items():
        entry: dict[str, Any] = {
            "algorithm": algorithm, "config_hash": job.config_hash,
            "summary": summaries[algorithm].as_dict(),
            "episodes": episode_band(matrices[algorithm], points),
            "weights": _weights(runs),
        }
        if include_seeds:
            entry["seeds"] = []
            for run, row in zip(runs, matrices[algorithm], strict=True):
                band = episode_band(row[np.newaxis, :], points)
                entry["seeds"].append({"seed": run.seed, "episode": band["episode"], "utility": band["mean"]})
        configurations.append(entry)
    return configurations


class _ResultsCache:
    """Serialized ``configurations`` of succeeded jobs (immutable once stored), least recently used out.

    Entries are built from the stored episodes and keyed by the job's id, configuration hash and
    finish time, so a deleted job's id reused by a new job never hits an old entry.
    """

    def __init__(self, max_bytes: int = 64 * 1024**2) -> None:
        self.max_bytes = max_bytes
        self._entries: OrderedDict[tuple, bytes] = OrderedDict()
        self._lock = threading.Lock()

    def get_or_build(self, key: tuple, build: Callable[[], bytes]) -> bytes:
        """The cached bytes of ``key``, building (outside the lock) and storing them when missing."""
        with self._lock:
            if key in self._entries:
                self._entries.move_to_end(key)
                return self._entries[key]
        value = build()
        with self._lock:
            self._entries[key] = value
            while sum(map(len, self._entries.values())) > self.max_bytes and len(self._entries) > 1:
                self._entries.popitem(last=False)
        return value


RESULTS_CACHE = _ResultsCache()


def _dumps(value: Any) -> bytes:
    return json.dumps(value, allow_nan=False, separators=(",", ":")).encode()


def job_results_json(session: Session, *, job_id: int, points: int | None = None,
                     include_seeds: bool = False) -> bytes:
    """``GET /api/jobs/{id}/results`` (docs/api.md "Results") as JSON bytes."""
    job = get_job(session, job_id=job_id)
    require_succeeded(job)
    key = (job.id, job.config_hash, job.finished_at, points, include_seeds)
    configurations = RESULTS_CACHE.get_or_build(
        key, lambda: _dumps(_configurations(session, job, points, include_seeds))
    )
    return (b'{"job":' + _dumps(job_dict(job)) + b',"paper":' + _dumps(paper_figures(job))
            + b',"configurations":' + configurations + b"}")


def job_results(session: Session, *, job_id: int, points: int | None = None,
                include_seeds: bool = False) -> dict[str, Any]:
    """``GET /api/jobs/{id}/results`` as data."""
    return json.loads(job_results_json(session, job_id=job_id, points=points, include_seeds=include_seeds))


def compare(session: Session, *, job_ids: Sequence[int], points: int | None = None) -> dict[str, Any]:
    """``GET /api/compare``: configurations ``(config_hash, algorithm)`` pooled over the jobs' seeds.

    Only succeeded jobs contribute groups; the others are listed in ``jobs`` and add nothing.
    """
    jobs = [get_job(session, job_id=job_id) for job_id in dict.fromkeys(job_ids)]
    order = {job.id: i for i, job in enumerate(jobs) if job.status == SUCCEEDED}
    runs = sorted(_runs(session, list(order)), key=lambda r: (order[r.job_id], r.id))
    jobs_by_id = {job.id: job for job in jobs}
    # (config_hash, algorithm) -> seed -> utilities; the first job holding a seed supplies it.
    pooled: dict[tuple[str, str], dict[int, np.ndarray]] = {}
    contributors: dict[tuple[str, str], list[int]] = {}
    for run in runs:
        key = (jobs_by_id[run.job_id].config_hash, run.algorithm)
        seeds = pooled.setdefault(key, {})
        ids = contributors.setdefault(key, [])
        if run.job_id not in ids:
            ids.append(run.job_id)
        seeds.setdefault(run.seed, utilities(run))
    summaries: dict[str, dict] = {}
    for config in dict.fromkeys(h for h, _ in pooled):
        finals = {
            algorithm: dict(zip(seeds, final_utilities(np.stack(list(seeds.values()))).tolist(), strict=True))
            for (h, algorithm), seeds in pooled.items() if h == config
        }
        summaries[config] = summarise(finals)
    groups = []
    for (config, algorithm), seeds in pooled.items():
        first = jobs_by_id[contributors[(config, algorithm)][0]]
        groups.append({
            "config_hash": config, "algorithm": algorithm, "system": first.system,
            "episodes_per_run": first.config["episodes"], "job_ids": contributors[(config, algorithm)],
            "summary": summaries[config][algorithm].as_dict(),
            "episodes": episode_band(np.stack(list(seeds.values())), points),
        })
    return {"jobs": [job_dict(job) for job in jobs], "groups": groups}


def stored_runs(session: Session, *, job_id: int) -> Iterator[tuple[str, int, list[float]]]:
    """Every stored run of a job as ``(algorithm, seed, utilities)``, fetched from the database a few at a time."""
    statement = (
        select(Run.algorithm, Run.seed, Run.utilities).where(Run.job_id == job_id)
        .order_by(Run.id).execution_options(yield_per=16)
    )
    for algorithm, seed, blob in session.execute(statement):
        yield algorithm, seed, np.frombuffer(blob, dtype="<f8").tolist()
