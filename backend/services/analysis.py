"""Results of a job, computed from the stored episodes with the core's aggregation (comparisons: comparison.py).

Runs are read a few at a time and folded into per-episode statistics, so the memory a request
needs grows with the episodes of a configuration, not with its runs. Every answer is bounded:
at most :data:`MAX_RESPONSE_VALUES` numbers in curves (beyond that the default downsamples and
an explicit request is refused with 422 naming the limit) and at most
:data:`backend.services.weights.MAX_WEIGHT_VALUES` learned weights per configuration, of the first page of children
(:data:`backend.services.weights.CHILDREN_PAGE`). A job that is still
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
from backend.store.models import RUN_READ_BATCH, SIMULATION, SUCCEEDED, Job, Run
from backend.store.summaries import in_seed_order, summary_dict
from mgrao_core import (
    PRESETS,
    ConfigError,
    EpisodeStats,
    TaskCounts,
    complete_params,
    final_utilities,
    make_params,
    paired_pct_from_uniform,
    summarise,
)
from mgrao_core.algorithms import describe_label, family_of, groups_at_end, parse_algorithm, task_share
from mgrao_core.algorithms.oracle import LABEL as ORACLE
from mgrao_core.algorithms.oracle import bound_caveats
from mgrao_core.reproduction import PAPER_EPISODES
from mgrao_core.statistics.summary import BASELINE

MAX_RESPONSE_VALUES = 1_000_000
"""Numbers in the curves of one results or compare answer (about 20 MB of JSON)."""
MAX_CONCURRENT_BUILDS = 2
"""Results or comparisons computed at once; more requests wait their turn (each build holds one
answer's arrays, up to :data:`MAX_RESPONSE_VALUES` numbers)."""
BUILDS = threading.BoundedSemaphore(MAX_CONCURRENT_BUILDS)
BAND_ARRAYS = 3
"""Arrays of one curve's band: mean, low, high (the episode index is shared)."""


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


class Learning:
    """What a learner configuration's learning came to over its stored runs (docs/api.md, "Results": ``learning``).

    Its children's parent groups at the end, and the share of their resources that learning took then.
    """

    def __init__(self, label: str, params: Any) -> None:
        self.algorithm = parse_algorithm(label, params.n_parents)
        self.family = family_of(self.algorithm)
        self.params = params
        self.recorded: dict[int, int] = {}

    def add(self, membership: bytes | None, meta: dict[str, Any] | None) -> None:
        """A run's recorded membership (of a family whose groups change): each recorded child's groups at the end."""
        if self.family.groups_change and membership is not None and meta:
            for groups in groups_at_end(weights.membership_history(membership, meta)).tolist():
                self.recorded[groups] = self.recorded.get(groups, 0) + 1

    def answer(self, runs: int) -> dict[str, Any] | None:
        """``{"groups", "children", "taken"}`` over ``runs`` runs, or None for a configuration that learns nothing."""
        if not self.family.learns:
            return None
        if self.family.groups_change:
            groups = dict(sorted(self.recorded.items()))
        else:
            groups = {self.algorithm.n_groups: runs * self.params.n_children} if self.algorithm.n_groups else {}
        children = sum(groups.values())
        taken = None
        if getattr(self.params, "learning_cost", 0.0):
            if self.family.groups_change:
                shares = {g: 1.0 - task_share(self.algorithm, self.params, g) for g in groups}
                taken = {"mean": sum(shares[g] * n for g, n in groups.items()) / children,
                         "low": min(shares.values()), "high": max(shares.values())} if groups else None
            else:
                share = 1.0 - task_share(self.algorithm, self.params)
                taken = {"mean": share, "low": share, "high": share}
        return {"groups": {str(g): n for g, n in groups.items()} or None, "children": children,
                "groups_change": self.family.groups_change, "taken": taken}


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
    curves = len(algorithms) * BAND_ARRAYS + (sum(seeds_done.values()) if include_seeds else 0)
    used = choose_points("points" if not include_seeds else "include_seeds", points, episodes, curves)
    per_seed: dict[str, list[dict[str, Any]]] = {a: [] for a in algorithms}
    tasks = {a: TaskCounts() for a in algorithms}
    params = job_params(job)
    learning = {a: Learning(a, params) for a in algorithms} if params is not None else {}
    for algorithm, seed, blob, allocated, failed, handed_over, membership, membership_meta in _stream(
            session, [job.id], Run.algorithm, Run.seed, Run.utilities, Run.tasks_allocated, Run.tasks_failed,
            Run.tasks_handed_over, Run.membership, Run.membership_meta):
        values = np.frombuffer(blob, dtype="<f8")
        stats[algorithm].add(values)
        finals[algorithm][seed] = float(final_utilities(values)[0])
        tasks[algorithm] += TaskCounts(allocated, failed, handed_over)
        if algorithm in learning:
            learning[algorithm].add(membership, membership_meta)
        if include_seeds:
            one = EpisodeStats(episodes)
            one.add(values)
            band = one.band_arrays(used)
            per_seed[algorithm].append({"seed": seed, "episode": band["episode"], "utility": band["mean"]})
    ordered = in_seed_order({a: finals[a] for a in algorithms if finals[a]}, job.config["seeds"])
    summaries = summarise(ordered)
    configurations = []
    for algorithm in algorithms:
        if not finals[algorithm]:
            continue
        entry: dict[str, Any] = {
            "algorithm": algorithm, "config_hash": job.config_hash, "seeds_done": seeds_done[algorithm],
            "summary": summary_dict(summaries[algorithm], tasks[algorithm]),
            "episodes": stats[algorithm].band_arrays(used),
            "weights": weights.mean_over_seeds(session, job.id, algorithm),
            "learning": learning[algorithm].answer(len(finals[algorithm])) if algorithm in learning else None,
        }
        if pct_by_seed:
            entry["pct_by_seed"] = _pct_by_seed(ordered[algorithm], ordered.get(BASELINE), seed_order)
        if include_seeds:
            entry["seeds"] = sorted(per_seed[algorithm], key=lambda s: seed_order.get(s["seed"], 0))
        configurations.append(entry)
    return {"points": used, "configurations": configurations}


def job_params(job: Job) -> Any:
    """A simulated job's resolved parameters (the core's).

    None for a job logged from outside, or one of a label the registry no longer knows.
    """
    if job.kind != SIMULATION:
        return None
    try:
        params = make_params(complete_params(job.config["params"]))
        for label in job.config["algorithms"]:
            parse_algorithm(label, params.n_parents)
    except ConfigError:
        return None
    return params


def oracle_caveats(job: Job) -> list[str] | None:
    """Why the job's oracle is no upper bound in its system (:func:`bound_caveats`; [] when it is one).

    None for a job without the oracle.
    """
    params = job_params(job)
    if params is None or ORACLE not in job.config["algorithms"]:
        return None
    return bound_caveats(params)


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
        with BUILDS:
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
            "oracle_caveats": oracle_caveats(job), "algorithms": described(job.config["algorithms"])}
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


def stored_runs(session: Session, *, job_id: int) -> Iterator[tuple[str, int, list[float]]]:
    """Every stored run of a job as ``(algorithm, seed, utilities)``, fetched from the database a few at a time."""
    for algorithm, seed, blob in _stream(session, [job_id], Run.algorithm, Run.seed, Run.utilities):
        yield algorithm, seed, np.frombuffer(blob, dtype="<f8").tolist()
