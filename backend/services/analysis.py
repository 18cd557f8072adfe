"""Results and comparisons, computed from the stored episodes with the core's aggregation.

Runs are read a few at a time and folded into per-episode statistics, so the memory a request
needs grows with the episodes of a configuration, not with its runs. Every answer is bounded:
at most :data:`MAX_RESPONSE_VALUES` numbers in curves (beyond that the default downsamples and
an explicit request is refused with 422 naming the limit) and at most
:data:`backend.services.weights.MAX_WEIGHT_VALUES` learned weights per configuration. A job that is still
running, or was cancelled or failed after storing some chunks, answers with what is stored, marked ``partial``.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import numpy as np
import orjson
from sqlalchemy import func, select
from sqlalchemy.orm import Session

from backend.errors import BadQuery, Conflict
from backend.services import weights
from backend.services.cache import AnswerCache
from backend.services.memory import trim
from backend.store.crud import get_job, job_dict
from backend.store.models import RUN_READ_BATCH, SUCCEEDED, Job, Run
from mgrao_core import (
    PRESETS,
    ConfigError,
    EpisodeStats,
    complete_params,
    final_utilities,
    paired_pct_from_uniform,
    summarise,
)
from mgrao_core.algorithms import describe_label
from mgrao_core.reproduction import PAPER_EPISODES
from mgrao_core.stats import BASELINE

MAX_RESPONSE_VALUES = 1_000_000
"""Numbers in the curves of one results or compare answer (about 20 MB of JSON)."""
MAX_CONCURRENT_BUILDS = 2
"""Results or comparisons computed at once; more requests wait their turn (each build holds one
answer's arrays, up to :data:`MAX_RESPONSE_VALUES` numbers)."""
_BUILDS = threading.BoundedSemaphore(MAX_CONCURRENT_BUILDS)
_BAND_ARRAYS = 3  # mean, low, high (the episode index is shared)


def utilities(run: Run) -> np.ndarray:
    """A run's episode utilities (float64, episode order)."""
    return np.frombuffer(run.utilities, dtype="<f8")


def require_runs(session: Session, job: Job) -> int:
    """The number of stored runs; :class:`Conflict` when the job has none yet."""
    stored = session.scalar(select(func.count()).select_from(Run).where(Run.job_id == job.id)) or 0
    if stored == 0:
        raise Conflict(f"job {job.id} is {job.status} and has no stored runs yet")
    return stored


def paper_figures(job: Job) -> dict[str, float] | None:
    """The paper's "% from uniform" for the job's algorithms, if it is the paper's experiment.

    That is: the preset's parameters unchanged and the paper's 100 episodes (its tables are
    "after 100 episodes"); any other job has no published figure to stand beside.
    """
    preset = PRESETS[job.system]
    if complete_params(job.config["params"]) != preset.params.as_dict() or job.config["episodes"] != PAPER_EPISODES:
        return None
    figures = {a: preset.paper_pct_from_uniform[a] for a in job.config["algorithms"]
               if a in preset.paper_pct_from_uniform}
    return figures or None


def choose_points(field: str, requested: int | None, episodes: int, curves: int) -> int:
    """Points per curve for ``curves`` curves of ``episodes`` episodes within :data:`MAX_RESPONSE_VALUES`.

    ``requested`` None: every episode if that fits, else the most that fit. An explicit request
    that does not fit is refused, naming ``field`` and the largest that would.
    """
    fitting = max(1, MAX_RESPONSE_VALUES // max(1, curves))
    if requested is None:
        return min(episodes, fitting)
    if min(requested, episodes) > fitting:
        raise BadQuery(field, f"{min(requested, episodes):,} points x {curves:,} curves exceeds the limit of "
                              f"{MAX_RESPONSE_VALUES:,} values per answer: use points <= {fitting:,}")
    return min(requested, episodes)


def _stream(session: Session, job_ids: Sequence[int], *columns: Any) -> Iterator[Any]:
    statement = (select(*columns).where(Run.job_id.in_(list(job_ids))).order_by(Run.job_id, Run.id)
                 .execution_options(yield_per=RUN_READ_BATCH))
    yield from session.execute(statement)


def _configurations(session: Session, job: Job, points: int | None, include_seeds: bool,
                    pct_by_seed: bool = False) -> dict[str, Any]:
    algorithms = job.config["algorithms"]
    episodes = job.config["episodes"]
    stats = {a: EpisodeStats(episodes) for a in algorithms}
    finals: dict[str, dict[int, float]] = {a: {} for a in algorithms}
    seed_order = {seed: i for i, seed in enumerate(job.config["seeds"])}
    stored_seeds = session.execute(
        select(Run.algorithm, func.count()).where(Run.job_id == job.id).group_by(Run.algorithm)
    ).all()
    seeds_done = {a: 0 for a in algorithms} | {a: n for a, n in stored_seeds}
    curves = len(algorithms) * _BAND_ARRAYS + (sum(seeds_done.values()) if include_seeds else 0)
    used = choose_points("points" if not include_seeds else "include_seeds", points, episodes, curves)
    per_seed: dict[str, list[dict[str, Any]]] = {a: [] for a in algorithms}
    for algorithm, seed, blob in _stream(session, [job.id], Run.algorithm, Run.seed, Run.utilities):
        values = np.frombuffer(blob, dtype="<f8")
        stats[algorithm].add(values)
        finals[algorithm][seed] = float(final_utilities(values)[0])
        if include_seeds:
            one = EpisodeStats(episodes)
            one.add(values)
            band = one.band_arrays(used)
            per_seed[algorithm].append({"seed": seed, "episode": band["episode"], "utility": band["mean"]})
    ordered = {a: dict(sorted(finals[a].items(), key=lambda kv: seed_order.get(kv[0], 0)))
               for a in algorithms if finals[a]}
    summaries = summarise(ordered)
    configurations = []
    for algorithm in algorithms:
        if not finals[algorithm]:
            continue
        entry: dict[str, Any] = {
            "algorithm": algorithm, "config_hash": job.config_hash, "seeds_done": seeds_done[algorithm],
            "summary": summaries[algorithm].as_dict(),
            "episodes": stats[algorithm].band_arrays(used),
            "weights": weights.mean_over_seeds(session, job.id, algorithm),
        }
        if pct_by_seed:
            entry["pct_by_seed"] = _pct_by_seed(ordered[algorithm], ordered.get(BASELINE), seed_order)
        if include_seeds:
            entry["seeds"] = sorted(per_seed[algorithm], key=lambda s: seed_order.get(s["seed"], 0))
        configurations.append(entry)
    return {"points": used, "configurations": configurations}


def _pct_by_seed(by_seed: dict[int, float], baseline: dict[int, float] | None,
                 seed_order: dict[int, int]) -> list[dict[str, Any]]:
    """Each seed's paired % from uniform (the values the summary's mean and interval are made of), in job order."""
    paired = paired_pct_from_uniform(by_seed, baseline)
    return [{"seed": seed, "pct_from_uniform": paired[seed]}
            for seed in sorted(paired, key=lambda seed: seed_order.get(seed, 0))]


RESULTS_CACHE = AnswerCache()


def described(labels: Iterable[str]) -> list[dict[str, Any]]:
    """The algorithm registry's description of each distinct label (``GET /api/algorithms?label=``).

    Answers that show configurations carry them, so that a view orders and colours them without
    asking again. A label no family recognises (a run logged from outside) is left out.
    """
    out = []
    for label in dict.fromkeys(labels):
        try:
            out.append(describe_label(label))
        except ConfigError:
            continue
    return out


def dumps(value: Any) -> bytes:
    """Compact JSON of data holding numpy arrays, without a Python object per number.

    A value that is not finite (a corrupted or legacy store) becomes ``null``.
    """
    return orjson.dumps(value, option=orjson.OPT_SERIALIZE_NUMPY)


def job_results_parts(session: Session, *, job_id: int, points: int | None = None,
                      include_seeds: bool = False, pct_by_seed: bool = False) -> tuple[bytes, bytes]:
    """``GET /api/jobs/{id}/results`` (docs/api.md "Results") as two pieces of JSON sent in turn.

    The job's head, then its configurations: the cached bytes themselves, not a copy.
    """
    job = get_job(session, job_id=job_id)
    stored = require_runs(session, job)
    partial = job.status != SUCCEEDED

    def build() -> bytes:
        with _BUILDS:
            try:
                return dumps(_configurations(session, job, points, include_seeds, pct_by_seed))
            finally:
                trim()

    if partial:  # still changing (or never complete): not cached
        body = build()
    else:
        key = (job.id, job.config_hash, job.finished_at, points, include_seeds, pct_by_seed)
        body = RESULTS_CACHE.get_or_build(key, build)
    expected = len(job.config["seeds"]) * len(job.config["algorithms"])
    head = {"job": job_dict(job), "paper": paper_figures(job), "partial": partial or stored < expected,
            "algorithms": described(job.config["algorithms"])}
    return dumps(head)[:-1] + b",", body


def job_results_json(session: Session, *, job_id: int, points: int | None = None,
                     include_seeds: bool = False, pct_by_seed: bool = False) -> bytes:
    """``GET /api/jobs/{id}/results`` as one piece of JSON."""
    head, body = job_results_parts(session, job_id=job_id, points=points, include_seeds=include_seeds,
                                   pct_by_seed=pct_by_seed)
    return head + body[1:]


def job_results(session: Session, *, job_id: int, points: int | None = None,
                include_seeds: bool = False, pct_by_seed: bool = False) -> dict[str, Any]:
    """``GET /api/jobs/{id}/results`` as data."""
    return json.loads(job_results_json(session, job_id=job_id, points=points, include_seeds=include_seeds,
                                       pct_by_seed=pct_by_seed))


def compare_json(session: Session, *, job_ids: Sequence[int], points: int | None = None) -> bytes:
    """``GET /api/compare`` as JSON: configurations ``(config_hash, algorithm)`` pooled over the jobs' seeds.

    Only succeeded jobs contribute groups; the others are listed in ``jobs`` and add nothing. A
    seed stored by two jobs of one configuration counts once (the first job's run). Groups are
    folded one at a time, so memory grows with a group's episodes, not with the jobs compared.

    The groups are kept (:data:`RESULTS_CACHE`) under what they are made of: each job's id, state,
    end and configuration, in the order asked, and ``points``. A job that ends, is run again or is
    deleted changes that key (or answers 404), so a kept answer is never stale; the jobs' own
    records (names, tags) are read afresh every time.
    """
    jobs = [get_job(session, job_id=job_id) for job_id in dict.fromkeys(job_ids)]
    key = ("compare", points, *((job.id, job.status, job.finished_at, job.config_hash) for job in jobs))

    def build() -> bytes:
        with _BUILDS:
            try:
                return dumps(_compare_groups(session, jobs, points))
            finally:
                trim()

    groups = RESULTS_CACHE.get_or_build(key, build)
    head = {"jobs": [job_dict(job) for job in jobs],
            "algorithms": described(a for job in jobs for a in job.config["algorithms"])}
    return dumps(head)[:-1] + b',"groups":' + groups + b"}"


def compare(session: Session, *, job_ids: Sequence[int], points: int | None = None) -> dict[str, Any]:
    """``GET /api/compare`` as data (:func:`compare_json`)."""
    return json.loads(compare_json(session, job_ids=job_ids, points=points))


def _compare_groups(session: Session, jobs: list[Job], points: int | None) -> list[dict[str, Any]]:
    succeeded = [job for job in jobs if job.status == SUCCEEDED]
    keys = list(dict.fromkeys((job.config_hash, a) for job in succeeded for a in job.config["algorithms"]))
    finals: dict[tuple[str, str], dict[int, float]] = {}
    bands: dict[tuple[str, str], dict[str, np.ndarray]] = {}
    contributors: dict[tuple[str, str], list[Job]] = {}
    for key in keys:
        config, algorithm = key
        members = [job for job in succeeded if job.config_hash == config]
        episodes = members[0].config["episodes"]
        stats = EpisodeStats(episodes)
        finals[key], contributors[key] = {}, []
        for job in members:
            statement = (select(Run.seed, Run.utilities).where(Run.job_id == job.id, Run.algorithm == algorithm)
                         .order_by(Run.id).execution_options(yield_per=RUN_READ_BATCH))
            for seed, blob in session.execute(statement):
                if seed in finals[key]:
                    continue
                values = np.frombuffer(blob, dtype="<f8")
                stats.add(values)
                finals[key][seed] = float(final_utilities(values)[0])
                if job not in contributors[key]:
                    contributors[key].append(job)
        bands[key] = stats.band_arrays(choose_points("points", points, episodes, len(keys) * _BAND_ARRAYS))
    summaries: dict[str, dict] = {}
    for config in dict.fromkeys(h for h, _ in keys):
        summaries[config] = summarise({a: finals[(h, a)] for h, a in keys if h == config and finals[(h, a)]})
    groups = []
    for key in keys:
        if not finals[key]:
            continue
        config, algorithm = key
        first = contributors[key][0]
        groups.append({
            "config_hash": config, "algorithm": algorithm, "system": first.system,
            "episodes_per_run": first.config["episodes"], "job_ids": [job.id for job in contributors[key]],
            "summary": summaries[config][algorithm].as_dict(),
            "episodes": bands[key],
        })
    return groups


def stored_runs(session: Session, *, job_id: int) -> Iterator[tuple[str, int, list[float]]]:
    """Every stored run of a job as ``(algorithm, seed, utilities)``, fetched from the database a few at a time."""
    for algorithm, seed, blob in _stream(session, [job_id], Run.algorithm, Run.seed, Run.utilities):
        yield algorithm, seed, np.frombuffer(blob, dtype="<f8").tolist()
