"""Stored jobs compared: which runs pool and pair (docs/statistics.md, "Pairing"), and the answers built on them.

The jobs' runs are read once for their final utilities and a digest of their bytes (:func:`gather`), and
sorted into *configurations* (:mod:`mgrao_core.statistics.pairing`): a world, a label and the label's own parameters.

* Built-in runs of one configuration pool, whichever jobs they come from: determinism makes a seed's run
  the same bytes in every job, which is checked; a seed whose pooled runs differ is listed in
  ``mismatched_seeds`` (the first job's run, in the order asked, is kept).
* Runs logged from outside pool when they have the same label, world and declared parameters and agree on
  every seed they share (a learner logged in parts over different seeds pools); other runs of the same
  label stay apart, each a configuration of its own, and so does a run that several such configurations
  would take (its seeds shared with none of them: which one it belongs to cannot be told).
* A label that two configurations would share (other own parameters, on any world; runs of one world that
  did not pool) is followed, on every world, by what tells its configurations apart:
  ``mgrao-1:1 (learning_rate=0.2)``, ``hedge (learning_rate=0.1; job 12)``; a configuration keeps its name on
  every world, so the aggregates across worlds never join two.
* A run whose final utility is not finite (a corrupted or legacy store) takes no part: its seed is listed in
  ``non_finite_seeds``.
* Worlds are named by their system, and where two worlds share one, by what differs between them:
  ``single (episodes=200)``. A world's system is the saved system its jobs ran where they ran one
  (:func:`_system_names`): ``large30``, not its base ``large``.

Every figure that relates two configurations is the core's (:mod:`mgrao_core.statistics`), on the seeds they
share. Memory grows with the runs compared (a final and a digest each, numpy arrays) and with one
configuration's episodes at a time for the curves.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.services.analysis import BAND_ARRAYS, BUILDS, RESULTS_CACHE, choose_points, described, dumps
from backend.services.memory import trim
from backend.store.crud import get_job, job_dict
from backend.store.models import EXTERNAL, RUN_READ_BATCH, SUCCEEDED, Job, Run, saved_system_of
from backend.store.summaries import summary_dict
from mgrao_core import ConfigError, EpisodeStats, TaskCounts, complete_params, final_utilities, make_params, summarise
from mgrao_core.algorithms import sort_key
from mgrao_core.algorithms.oracle import bound_caveats
from mgrao_core.statistics.comparison import compare as compare_worlds
from mgrao_core.statistics.comparison import sample_efficiency
from mgrao_core.statistics.pairing import own_values, world, world_digest
from mgrao_core.statistics.scores import World

MAX_CURVE_POINTS = 50
"""Buckets of episodes of a sample-efficiency curve at most."""
_SUFFIX_PARAMS = 3
"""Parameters named in a world's or a configuration's suffix at most (then an ellipsis and a short digest)."""


@dataclass
class _Runs:
    """One (job, algorithm)'s stored runs: seeds, final utilities and digests of their bytes, in storage order.

    ``tasks`` holds each run's task counts (allocated, failed, handed over), ``(runs, 3)``.
    """

    seeds: np.ndarray
    finals: np.ndarray
    digests: np.ndarray
    tasks: np.ndarray


@dataclass
class Configuration:
    """A configuration of the comparison and the runs it takes, seed by seed."""

    world: str
    algorithm: str
    own: dict[str, Any]
    external: bool
    jobs: list[Job] = field(default_factory=list)
    taken: dict[int, tuple[int, bytes, float]] = field(default_factory=dict)
    """Seed -> (job id, digest, final utility) of the run it takes."""
    mismatched: list[int] = field(default_factory=list)
    non_finite: list[int] = field(default_factory=list)
    """Seeds whose final utility is not finite: left out."""
    tasks: dict[int, TaskCounts] = field(default_factory=dict)
    """Seed -> the task counts of the run it takes."""
    label: str = ""

    def agrees(self, runs: _Runs) -> bool:
        """Whether every seed both have is the same bytes."""
        return all(self.taken[s][1] == d for s, d in zip(runs.seeds.tolist(), runs.digests.tolist(), strict=True)
                   if s in self.taken)

    def add(self, job: Job, runs: _Runs) -> None:
        """Take the job's runs of seeds not taken yet; a seed taken with other bytes is mismatched."""
        self.jobs.append(job)
        for seed, final, digest, tasks in zip(runs.seeds.tolist(), runs.finals.tolist(), runs.digests.tolist(),
                                              runs.tasks.tolist(), strict=True):
            if not math.isfinite(final):
                if seed not in self.non_finite:
                    self.non_finite.append(seed)
                continue
            known = self.taken.get(seed)
            if known is None:
                self.taken[seed] = (job.id, digest, final)
                self.tasks[seed] = TaskCounts(*tasks)
            elif known[1] != digest and seed not in self.mismatched:
                self.mismatched.append(seed)

    @property
    def job_ids(self) -> list[int]:
        """Every job read for the configuration, in the order asked: those whose runs stand and those only checked."""
        return list(dict.fromkeys(job.id for job in self.jobs))

    @property
    def checked_job_ids(self) -> list[int]:
        """The jobs read whose every seed an earlier job gave first: checked against it (``mismatched``), none used."""
        standing = {job_id for job_id, _, _ in self.taken.values()}
        return [job_id for job_id in self.job_ids if job_id not in standing]

    @property
    def finals(self) -> dict[int, float]:
        """Seed -> final utility, in seed order."""
        return {seed: self.taken[seed][2] for seed in sorted(self.taken)}

    @property
    def task_counts(self) -> TaskCounts:
        """The task counts of the runs it takes, summed over seeds (its rates pool every atomic task)."""
        return sum(self.tasks.values(), TaskCounts())


@dataclass
class Gathered:
    """The compared jobs sorted into worlds and configurations."""

    jobs: list[Job]
    worlds: dict[str, str]
    """World digest -> its name, in the order first met."""
    configurations: list[Configuration]
    systems: dict[str, str] = field(default_factory=dict)
    """World digest -> its system's name (:func:`_system_names`): a saved system's where its jobs ran one."""
    bases: dict[str, str] = field(default_factory=dict)
    """World digest -> the preset its system is based on (its jobs' ``system``)."""

    def of_world(self, digest: str) -> list[Configuration]:
        """The world's configurations in the order views show them."""
        return [c for c in self.configurations if c.world == digest]


def _digest(blob: bytes) -> bytes:
    return hashlib.blake2b(blob, digest_size=16).digest()


def _read_runs(session: Session, jobs: Sequence[Job]) -> dict[tuple[int, str], _Runs]:
    """Every stored run of the jobs as its final utility, digest and task counts, by (job id, algorithm)."""
    found: dict[tuple[int, str], list[tuple[int, float, bytes, tuple[int, int, int]]]] = {}
    ids = [job.id for job in jobs]
    if not ids:
        return {}
    statement = (select(Run.job_id, Run.algorithm, Run.seed, Run.utilities, Run.tasks_allocated, Run.tasks_failed,
                        Run.tasks_handed_over).where(Run.job_id.in_(ids))
                 .order_by(Run.job_id, Run.id).execution_options(yield_per=RUN_READ_BATCH))
    for job_id, algorithm, seed, blob, *tasks in session.execute(statement):
        values = np.frombuffer(blob, dtype="<f8")
        found.setdefault((job_id, algorithm), []).append(
            (seed, float(final_utilities(values)[0]), _digest(blob), tuple(tasks)))
    return {key: _Runs(np.array([r[0] for r in rows], dtype=np.int64), np.array([r[1] for r in rows]),
                       np.array([r[2] for r in rows], dtype="S16"), np.array([r[3] for r in rows], dtype=np.int64))
            for key, rows in found.items()}


def _show(value: Any) -> str:
    return json.dumps(value) if isinstance(value, list | dict) else ("null" if value is None else str(value))


def _differing(items: dict[Any, dict[str, Any]]) -> list[str]:
    """The keys whose values differ between the items, sorted."""
    names = sorted({k for values in items.values() for k in values})
    first = next(iter(items.values()))
    return [n for n in names if any(values.get(n) != first.get(n) for values in items.values())]


def _suffix(values: dict[str, Any], names: list[str]) -> str:
    shown = ", ".join(f"{n}={_show(values.get(n))}" for n in names[:_SUFFIX_PARAMS])
    return shown + (", ..." if len(names) > _SUFFIX_PARAMS else "")


def _system_names(jobs: Sequence[Job]) -> tuple[dict[str, str], dict[str, str]]:
    """Each world's system name and base preset, by world digest (docs/statistics.md, "Names").

    A world's system is the saved system its jobs ran (their tag ``system:<name>``), even beside jobs of the
    base preset with the same overrides: those are the same system, and the preset's name would present it
    as the preset's (a 30-parent ``large30`` as the paper's ``large``). One definition saved under several
    names, and run under each, is named by all of them in alphabetical order: ``large30 = thirty``. A world
    none of whose jobs ran a saved system is named by its preset. The name is the system's, whatever the
    world's episodes: every world of one system (one base, one set of parameters) in a comparison has the
    same name, wherever its jobs come in the order asked.
    """
    saved: dict[str, set[str]] = {}
    keys: dict[str, str] = {}
    bases: dict[str, str] = {}
    for job in jobs:
        described = world(job.config)
        key = json.dumps({"base": described["system"], "params": described["params"]}, sort_keys=True)
        digest = world_digest(job.config)
        keys[digest], bases[digest] = key, described["system"]
        named = saved.setdefault(key, set())
        if (name := saved_system_of(job.tags)) is not None:
            named.add(name)
    return {digest: " = ".join(sorted(saved[key])) or bases[digest] for digest, key in keys.items()}, bases


def _world_names(jobs: Sequence[Job], systems: dict[str, str]) -> dict[str, str]:
    """Each world's name: its system's (``systems``, by digest), and where worlds share one, what differs.

    What differs between them may be their base preset too (one saved name, redefined on another base).
    """
    worlds: dict[str, dict[str, Any]] = {}
    for job in jobs:
        digest = world_digest(job.config)
        if digest not in worlds:
            described = world(job.config)
            worlds[digest] = {"system": systems[digest], "base": described["system"],
                              "episodes": described["episodes"]} | described["params"]
    names = {}
    for digest, values in worlds.items():
        peers = {d: v for d, v in worlds.items() if v["system"] == values["system"]}
        if len(peers) == 1:
            names[digest] = values["system"]
            continue
        differ = _differing(peers)
        names[digest] = f"{values['system']} ({_suffix(values, differ)})"
    counts: dict[str, int] = {}
    for name in names.values():
        counts[name] = counts.get(name, 0) + 1
    return {d: (n if counts[n] == 1 else f"{n} [{d[:6]}]") for d, n in names.items()}


def _label(configurations: list[Configuration]) -> None:
    """Set each configuration's label: its algorithm, and what tells it from the comparison's others of it.

    Others: other own parameters on any world, or runs of one world that did not pool. A configuration's
    parameters give the same label on every world, and no two configurations of one algorithm but the same
    parameters share one: parameters past the few named add a short digest of them.
    """
    by_algorithm: dict[str, list[Configuration]] = {}
    for c in configurations:
        by_algorithm.setdefault(c.algorithm, []).append(c)
    for algorithm, group in by_algorithm.items():
        identity = {id(c): json.dumps(c.own, sort_keys=True) for c in group}
        identities = {identity[id(c)]: c.own for c in group}
        pools = Counter((c.world, identity[id(c)]) for c in group)
        differ = _differing(identities) if len(identities) > 1 else []
        suffix = {key: _suffix(own, differ) if differ else "" for key, own in identities.items()}
        repeated = Counter(suffix.values())
        for key in suffix:
            if repeated[suffix[key]] > 1 and len(identities) > 1:
                digest = hashlib.sha256(key.encode()).hexdigest()[:6]
                suffix[key] = f"{suffix[key]}; #{digest}" if suffix[key] else f"#{digest}"
        for c in group:
            parts = [suffix[identity[id(c)]]] if suffix[identity[id(c)]] else []
            if pools[(c.world, identity[id(c)])] > 1:  # runs from outside that did not pool: their first job
                parts.append(f"job {c.jobs[0].id}")
            c.label = f"{algorithm} ({'; '.join(parts)})" if parts else algorithm


def gather(session: Session, jobs: Sequence[Job]) -> Gathered:
    """The succeeded jobs' runs sorted into worlds and configurations (the module's docstring)."""
    succeeded = [job for job in jobs if job.status == SUCCEEDED]
    runs = _read_runs(session, succeeded)
    configurations: list[Configuration] = []
    for job in succeeded:
        digest = world_digest(job.config)
        for algorithm in job.config["algorithms"]:
            stored = runs.get((job.id, algorithm))
            if stored is None:
                continue
            own = own_values(algorithm, job.config)
            external = job.kind == EXTERNAL
            candidates = [c for c in configurations if c.world == digest and c.algorithm == algorithm
                          and c.own == own and c.external == external]
            if external:  # joins the one pool it agrees with; none, or several (which?), and it stands apart
                agreeing = [c for c in candidates if c.agrees(stored)]
                target = agreeing[0] if len(agreeing) == 1 else None
            else:
                target = candidates[0] if candidates else None
            if target is None:
                target = Configuration(digest, algorithm, own, external)
                configurations.append(target)
            target.add(job, stored)
    _label(configurations)
    systems, bases = _system_names(succeeded)
    names = _world_names(succeeded, systems)
    order = {d: i for i, d in enumerate(names)}
    configurations.sort(key=lambda c: (order[c.world], sort_key(c.algorithm), c.label))
    return Gathered(list(jobs), names, configurations, systems, bases)


def _caveats(job: Job) -> list[str]:
    return bound_caveats(make_params(complete_params(job.config["params"])))


def worlds_of(gathered: Gathered, curves: dict[str, dict[int, np.ndarray]] | None = None) -> list[World]:
    """The core's worlds of a gathering (with each configuration's curves by label, if given)."""
    out = []
    for digest, name in gathered.worlds.items():
        configurations = gathered.of_world(digest)
        first = configurations[0].jobs[0]
        out.append(World(name=name, system=gathered.systems[digest], episodes=first.config["episodes"],
                         finals={c.label: c.finals for c in configurations}, caveats=_caveats(first),
                         curves=None if curves is None else {c.label: curves[_key(c)] for c in configurations
                                                             if _key(c) in curves}))
    return out


def _key(c: Configuration) -> str:
    return f"{c.world}:{c.label}"


def _jobs(session: Session, job_ids: Sequence[int]) -> list[Job]:
    return [get_job(session, job_id=job_id) for job_id in dict.fromkeys(job_ids)]


def _state(jobs: Sequence[Job]) -> tuple:
    """What an answer about these jobs is made of: each job's id, state, end, configuration and saved system.

    (The saved system is a tag, which names its world's system: :func:`_system_names`.) In the order asked.
    """
    return tuple((job.id, job.status, job.finished_at, job.config_hash, saved_system_of(job.tags)) for job in jobs)


def _head(jobs: Sequence[Job]) -> bytes:
    head = {"jobs": [job_dict(job) for job in jobs],
            "algorithms": described(a for job in jobs for a in job.config["algorithms"])}
    return dumps(head)[:-1]


def compare_json(session: Session, *, job_ids: Sequence[int], points: int | None = None) -> bytes:
    """``GET /api/compare`` as JSON: the jobs, and their configurations pooled over their seeds (``groups``).

    Only succeeded jobs contribute; the others are listed in ``jobs`` and add nothing. Each group is a
    configuration (the module's docstring) with its summary, on its world's pairing, and its curve (mean and
    95% band per episode). The groups are kept (:data:`RESULTS_CACHE`) under the jobs' state, in the order
    asked, and ``points``; the jobs' own records (names, tags) are read afresh every time.
    """
    jobs = _jobs(session, job_ids)

    def build() -> bytes:
        with BUILDS:
            try:
                return dumps(_groups(session, gather(session, jobs), points))
            finally:
                trim()

    groups = RESULTS_CACHE.get_or_build(("compare", points, *_state(jobs)), build)
    return _head(jobs) + b',"groups":' + groups + b"}"


def compare(session: Session, *, job_ids: Sequence[int], points: int | None = None) -> dict[str, Any]:
    """``GET /api/compare`` as data (:func:`compare_json`)."""
    return json.loads(compare_json(session, job_ids=job_ids, points=points))


def _groups(session: Session, gathered: Gathered, points: int | None) -> list[dict[str, Any]]:
    curves = len(gathered.configurations) * BAND_ARRAYS
    groups = []
    for digest, name in gathered.worlds.items():
        configurations = gathered.of_world(digest)
        summaries = summarise({c.label: c.finals for c in configurations})
        for c in configurations:
            episodes = c.jobs[0].config["episodes"]
            stats = EpisodeStats(episodes)
            for _, values in _taken_runs(session, c):
                stats.add(values)
            summary = summaries[c.label]
            groups.append({
                "config_hash": c.jobs[0].config_hash,
                "config_hashes": list(dict.fromkeys(j.config_hash for j in c.jobs)),
                "algorithm": c.algorithm, "label": c.label, "system": gathered.systems[digest],
                "base": gathered.bases[digest], "world": name,
                "params": c.own, "external": c.external, "episodes_per_run": episodes,
                "job_ids": c.job_ids, "checked_job_ids": c.checked_job_ids,
                "mismatched_seeds": sorted(c.mismatched), "non_finite_seeds": sorted(c.non_finite),
                "summary": summary_dict(summary, c.task_counts),
                "episodes": stats.band_arrays(choose_points("points", points, episodes, curves)),
            })
    return groups


def _taken_runs(session: Session, c: Configuration) -> Iterator[tuple[int, np.ndarray]]:
    """``(seed, utilities)`` of each run the configuration takes, read a few at a time."""
    wanted = {(job_id, seed) for seed, (job_id, _, _) in c.taken.items()}
    statement = (select(Run.job_id, Run.seed, Run.utilities)
                 .where(Run.job_id.in_([job.id for job in c.jobs]), Run.algorithm == c.algorithm)
                 .order_by(Run.job_id, Run.id).execution_options(yield_per=RUN_READ_BATCH))
    for job_id, seed, blob in session.execute(statement):
        if (job_id, seed) in wanted:
            yield seed, np.frombuffer(blob, dtype="<f8")


def standing_for(gathered: Gathered, job_ids: Sequence[int]) -> list[str]:
    """The worlds of ``job_ids`` (among the compared jobs), which stand for their systems in the aggregates.

    Raises:
        ConfigError: (field ``aggregate``) an id that is not one of the compared, succeeded jobs.
    """
    by_id = {job.id: job for job in gathered.jobs if job.status == SUCCEEDED}
    unknown = [job_id for job_id in job_ids if job_id not in by_id]
    if unknown:
        raise ConfigError("aggregate", f"job(s) {', '.join(map(str, unknown))}: not among the compared jobs that "
                                       f"succeeded (jobs: {', '.join(map(str, by_id))})")
    return list(dict.fromkeys(gathered.worlds[world_digest(by_id[job_id].config)] for job_id in job_ids))


@dataclass(frozen=True)
class Pending:
    """An answer of the comparison statistics, to compute (docs/service.md, "Statistics under load").

    ``key`` is what the answer is in :data:`RESULTS_CACHE` (the kind, its query and the jobs' state), ``build``
    computes its bytes from a session of the caller's (a thread of the statistics' pool opens its own), and
    :meth:`answer` gives the route's data from those bytes.
    """

    key: tuple
    what: str
    """How a log line names it."""
    build: Callable[[Session], bytes]
    extra: dict[str, Any] = field(default_factory=dict)
    """Added to the cached answer's data (what is read afresh, not kept)."""

    def cached(self) -> bytes | None:
        """The kept answer, if any (nothing is computed)."""
        return RESULTS_CACHE.get(self.key)

    def compute(self, session: Session) -> bytes:
        """The answer's bytes: kept, or built on ``session`` and kept."""
        return RESULTS_CACHE.get_or_build(self.key, lambda: self.build(session))

    def answer(self, body: bytes) -> dict[str, Any]:
        """The route's data from the answer's bytes."""
        return json.loads(body) | self.extra


def pending_statistics(session: Session, *, job_ids: Sequence[int], repetitions: int, seed: int,
                       aggregate: Sequence[int] = ()) -> Pending:
    """``GET /api/compare/statistics``, to compute: :func:`mgrao_core.statistics.comparison.compare` of the jobs.

    ``aggregate``: jobs whose worlds stand for their systems in the aggregates (:func:`standing_for`).
    """
    jobs = _jobs(session, job_ids)

    def build(s: Session) -> bytes:
        try:
            gathered = gather(s, jobs)
            answer = compare_worlds(worlds_of(gathered), repetitions=repetitions, seed=seed,
                                    aggregate=standing_for(gathered, aggregate))
            _add_task_rates(answer["systems"], gathered)
            answer["configurations"] = _described_configurations(gathered)
            return dumps(answer)
        finally:
            trim()

    return Pending(("statistics", repetitions, seed, tuple(aggregate), *_state(jobs)),
                   f"statistics of jobs {[job.id for job in jobs]} (reps={repetitions}, seed={seed}, "
                   f"aggregate={list(aggregate)})", build,
                   {"jobs": [job.id for job in jobs]})


def statistics(session: Session, *, job_ids: Sequence[int], repetitions: int, seed: int,
               aggregate: Sequence[int] = ()) -> dict[str, Any]:
    """``GET /api/compare/statistics`` as data, computed here (:func:`pending_statistics`)."""
    pending = pending_statistics(session, job_ids=job_ids, repetitions=repetitions, seed=seed, aggregate=aggregate)
    return pending.answer(pending.compute(session))


def _add_task_rates(systems: dict[str, dict[str, dict[str, Any]]], gathered: Gathered) -> None:
    """Each configuration's summary in ``systems`` (world, then label) with its task rates, as in compare's groups."""
    for c in gathered.configurations:
        summary = systems.get(gathered.worlds[c.world], {}).get(c.label)
        if summary is not None:
            summary.update(c.task_counts.rates())


def _described_configurations(gathered: Gathered) -> list[dict[str, Any]]:
    """What each configuration of an answer is: its world, algorithm, own parameters, jobs and mismatched seeds."""
    return [{"system": gathered.worlds[c.world], "base": gathered.bases[c.world], "label": c.label,
             "algorithm": c.algorithm, "params": c.own,
             "external": c.external, "job_ids": c.job_ids, "checked_job_ids": c.checked_job_ids,
             "mismatched_seeds": sorted(c.mismatched), "non_finite_seeds": sorted(c.non_finite)}
            for c in gathered.configurations]


def pending_sample_efficiency(session: Session, *, job_ids: Sequence[int], points: int, repetitions: int,
                              seed: int, aggregate: Sequence[int] = ()) -> Pending:
    """``GET /api/compare/sample-efficiency``, to compute: IQM of the scores per bucket of episodes, with bands.

    Each world's episodes are cut into ``points`` equal buckets (fewer when it has fewer episodes: then every
    world takes the smallest count), and a run's bucket is the mean of its utilities over it.
    """
    jobs = _jobs(session, job_ids)

    def build(s: Session) -> bytes:
        try:
            gathered = gather(s, jobs)
            episodes = {digest: gathered.of_world(digest)[0].jobs[0].config["episodes"] for digest in gathered.worlds}
            count = min([points, *episodes.values()]) if episodes else points
            curves = {}
            for c in gathered.configurations:
                edges = np.linspace(0, episodes[c.world], count + 1).round().astype(int)
                by_seed = {}
                for seed_, values in _taken_runs(s, c):
                    by_seed[seed_] = np.add.reduceat(values, edges[:-1]) / np.diff(edges)
                curves[_key(c)] = by_seed
            answer = sample_efficiency(worlds_of(gathered, curves), repetitions=repetitions, seed=seed,
                                       aggregate=standing_for(gathered, aggregate))
            answer["points"] = count
            answer["episodes"] = {gathered.worlds[d]: np.linspace(0, e, count + 1).round().astype(int)[:-1].tolist()
                                  for d, e in episodes.items()}
            return dumps(answer)
        finally:
            trim()

    return Pending(("sample-efficiency", points, repetitions, seed, tuple(aggregate), *_state(jobs)),
                   f"sample efficiency of jobs {[job.id for job in jobs]} (points={points}, reps={repetitions}, "
                   f"seed={seed})", build)


def sample_efficiency_answer(session: Session, *, job_ids: Sequence[int], points: int, repetitions: int,
                             seed: int, aggregate: Sequence[int] = ()) -> dict[str, Any]:
    """``GET /api/compare/sample-efficiency`` as data, computed here (:func:`pending_sample_efficiency`)."""
    pending = pending_sample_efficiency(session, job_ids=job_ids, points=points, repetitions=repetitions, seed=seed,
                                        aggregate=aggregate)
    return pending.answer(pending.compute(session))
