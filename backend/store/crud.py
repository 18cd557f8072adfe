"""Data functions on jobs: create, read, list (filters, keyset pagination), update, cancel, delete."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from datetime import datetime
from typing import Any

import orjson
from sqlalchemy import (
    ColumnElement,
    Row,
    Select,
    Text,
    bindparam,
    cast,
    delete,
    exists,
    func,
    insert,
    select,
    update,
)
from sqlalchemy.orm import Session

import mgrao_core
from backend.errors import Conflict, NotFound
from backend.store.job_order import parse_sort
from backend.store.models import (
    CANCELLED,
    QUEUED,
    RUNNING,
    SAVED_SYSTEM_TAG_PREFIX,
    SEARCH_SEPARATOR,
    SIMULATION,
    Job,
    JobSearch,
    JobTag,
    saved_system_of,
    utcnow,
)
from mgrao_core import PRESETS, ExperimentSpec, complete_params
from mgrao_core.statistics.sequential import Until, coverage_of, stopped_dict


def config_hash(config: dict[str, Any]) -> str:
    """sha256 of the canonical JSON of a configuration without its seeds, algorithms and stopping rule.

    A *configuration* in comparisons is ``(config_hash, algorithm)``: system, resolved
    parameters and episodes; lanes are independent, so seeds and the other algorithms of a
    job never change a run's numbers.
    """
    core = {k: v for k, v in config.items() if k not in ("seeds", "algorithms", "until")}
    canonical = json.dumps(core, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(canonical.encode()).hexdigest()


def iso(moment: datetime | None) -> str | None:
    """ISO 8601 UTC text of a stored (naive UTC) time."""
    return None if moment is None else moment.isoformat(timespec="milliseconds") + "Z"


def job_dict(job: Job | Row, config: dict[str, Any] | None = None) -> dict[str, Any]:
    """A job as the API shows it (docs/api.md "Job"): a model, or a row of :data:`LISTED` with its ``config``."""
    config = job.config if config is None else config
    duration = None
    if job.started_at is not None and job.finished_at is not None:
        duration = round((job.finished_at - job.started_at).total_seconds(), 3)
    queued = None if job.started_at is None else round(max(0.0, (job.started_at - job.created_at).total_seconds()), 3)
    return {
        "id": job.id, "name": job.name, "tags": list(job.tags), "notes": job.notes,
        "system": job.system, "algorithms": config["algorithms"], "seeds": config["seeds"],
        "episodes": config["episodes"], "params": complete_params(config["params"]), "config_hash": job.config_hash,
        "status": job.status, "progress": job.progress, "attempts": job.attempts, "error": job.error,
        "requeue_reason": job.requeue_reason,
        "created_at": iso(job.created_at), "started_at": iso(job.started_at),
        "finished_at": iso(job.finished_at), "duration_s": duration, "queued_s": queued,
        "compile_s": job.compile_s, "compiling": job.compiling if job.status == RUNNING else None,
        "version": job.version,
        "study_id": job.study_id, "trial_id": job.trial_id, "kind": job.kind,
        "saved_system": saved_system_of(job.tags),
        "until": config.get("until"), "stopped": stopped_of(job.status, config, job.stopped),
    }


"""What a job with a stopping rule says before its first block is judged."""


def stopped_of(status: str, config: dict[str, Any], stopped: dict[str, Any] | None) -> dict[str, Any] | None:
    """A job's ``stopped`` as the API shows it: None without a rule; a cancelled job's reason is ``cancelled``."""
    if not config.get("until"):
        return None
    stopped = (stopped or stopped_dict((), config["until"])) | coverage_of(config["until"])  # stored before: added
    if status == CANCELLED and stopped["reason"] is None:
        return stopped | {"reason": "cancelled"}
    return stopped


def set_tags(session: Session, job: Job, tags: Sequence[str]) -> None:
    """Give ``job`` these tags (repeats dropped), for the listing's ``tag`` filter too."""
    unique = list(dict.fromkeys(tags))
    job.tags = unique
    job.tag_rows = [JobTag(tag=t) for t in unique]


def search_text(name: str, notes: str, tags: Sequence[str]) -> str:
    """What the listing's ``q`` searches in a job (:class:`~backend.store.models.JobSearch`): name, notes, each tag.

    Joined by a newline, which no name or tag holds: a text without one is found in the joined text exactly where
    it is found in the name, the notes or a tag. Stored lowered by the database's ``lower`` (:func:`add_search_rows`,
    :func:`index_labels`), as the search lowered each of them before.
    """
    return SEARCH_SEPARATOR.join([name, notes, *tags])


def add_search_rows(session: Session, rows: Sequence[tuple[int, str, str, Sequence[str]]]) -> None:
    """Insert the search rows of new jobs, each given as ``(job_id, name, notes, tags)``, in one statement."""
    if rows:
        session.execute(insert(JobSearch).values(text=func.lower(bindparam("labels"))),
                        [{"job_id": job_id, "labels": search_text(name, notes, tags)}
                         for job_id, name, notes, tags in rows])


def index_labels(job: Job) -> None:
    """Write ``job``'s name, notes and tags as its search row; call after any of them changes (before the flush)."""
    text = func.lower(search_text(job.name, job.notes, job.tags))
    if job.search_row is None:
        job.search_row = JobSearch(text=text)
    else:
        job.search_row.text = text


def job_config(spec: ExperimentSpec, until: Until | None) -> dict[str, Any]:
    """A job's stored configuration: the spec's, with its stopping rule when it has one."""
    return spec.as_dict() | ({} if until is None else {"until": until.as_dict()})


def create_job(
    session: Session, *, spec: ExperimentSpec, name: str = "", tags: Sequence[str] = (), notes: str = "",
    study_id: int | None = None, trial_id: int | None = None, until: Until | None = None,
) -> Job:
    """Add a queued job for a validated spec (the caller commits); a study's trial names its study and trial.

    With ``until`` (a stopping rule, :func:`mgrao_core.statistics.sequential.make_until`), ``spec`` runs
    ``until.max_seeds`` seeds at most, in blocks, until the rule answers (docs/statistics.md "Seeds until decided").
    """
    config = job_config(spec, until)
    job = Job(
        name=name, notes=notes, system=spec.system, config=config, config_hash=config_hash(config), kind=SIMULATION,
        status=QUEUED, progress=0.0, attempts=0, version=mgrao_core.__version__, created_at=utcnow(),
        study_id=study_id, trial_id=trial_id, work=spec.work,
    )
    set_tags(session, job, tags)
    index_labels(job)
    session.add(job)
    session.flush()
    return job


def create_jobs(session: Session, *, jobs: Sequence[dict[str, Any]]) -> list[int]:
    """Add many queued jobs in two statements (the caller commits); their ids, in order.

    Each item holds ``spec`` (validated) and, as :func:`create_job` takes them, ``name``, ``tags``,
    ``notes``, ``study_id``, ``trial_id`` and ``until``: each job is the same as :func:`create_job` makes.
    """
    if not jobs:
        return []
    now, version = utcnow(), mgrao_core.__version__
    rows, tags = [], []
    for item in jobs:
        spec = item["spec"]
        config = job_config(spec, item.get("until"))
        unique = list(dict.fromkeys(item.get("tags", ())))
        tags.append(unique)
        rows.append({"name": item.get("name", ""), "tags": unique, "notes": item.get("notes", ""),
                     "system": spec.system, "config": config, "config_hash": config_hash(config), "status": QUEUED,
                     "progress": 0.0, "attempts": 0, "version": version, "created_at": now,
                     "study_id": item.get("study_id"), "trial_id": item.get("trial_id"), "work": spec.work})
    ids = list(session.scalars(insert(Job).returning(Job.id, sort_by_parameter_order=True), rows))
    tag_rows = [{"job_id": job_id, "tag": tag} for job_id, unique in zip(ids, tags, strict=True) for tag in unique]
    if tag_rows:
        session.execute(insert(JobTag), tag_rows)
    add_search_rows(session, [(job_id, row["name"], row["notes"], row["tags"])
                              for job_id, row in zip(ids, rows, strict=True)])
    return ids


def get_job(session: Session, *, job_id: int) -> Job:
    """The job, or :class:`NotFound`."""
    job = session.get(Job, job_id)
    if job is None:
        raise NotFound(f"job {job_id} not found")
    return job


def update_job(
    session: Session, *, job_id: int, name: str | None = None, tags: Sequence[str] | None = None,
    notes: str | None = None,
) -> Job:
    """Change a job's labels (any status)."""
    job = get_job(session, job_id=job_id)
    if name is not None:
        job.name = name
    if notes is not None:
        job.notes = notes
    if tags is not None:
        set_tags(session, job, tags)
    if (name, notes, tags) != (None, None, None):
        index_labels(job)
    return job


def cancel_job(session: Session, *, job_id: int) -> Job:
    """Cancel a queued or running job in one conditional update.

    A running job's worker notices at its next heartbeat (its lease is gone); the chunks it stored
    stay (the job is partial).
    """
    result = session.execute(
        update(Job).where(Job.id == job_id, Job.status.in_((QUEUED, RUNNING)))
        .values(status=CANCELLED, lease=None, finished_at=utcnow())
    )
    job = get_job(session, job_id=job_id)
    if result.rowcount != 1:
        raise Conflict(f"job {job_id} is {job.status}: only queued or running jobs can be cancelled")
    session.refresh(job)
    return job


def delete_job(session: Session, *, job_id: int) -> None:
    """Delete a job that is not running, with its runs and tags, in one conditional delete."""
    result = session.execute(delete(Job).where(Job.id == job_id, Job.status != RUNNING))
    if result.rowcount != 1:
        job = get_job(session, job_id=job_id)
        raise Conflict(f"job {job_id} is {job.status}: cancel it first")


def count_by_status(session: Session) -> dict[str, int]:
    """Number of jobs per status."""
    rows = session.execute(select(Job.status, func.count()).group_by(Job.status)).all()
    return {status: count for status, count in rows}


# ---- listing ---------------------------------------------------------------------------------

def _escape_like(text: str) -> str:
    return text.replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_")


SEARCH_FEW = 1000
"""Up to this many jobs found, a search's page is read from its matches (sorted); beyond, from the sort's order.

A page of a search either reads every match and sorts them (a key lookup each: about 2.5 us on SQLite here) or
reads the jobs in the page's order and checks each one's search row until the page is full (about 0.5 us each,
``limit`` x jobs / matches of them). Below about 1,000 matches of 100,000 jobs the first reads less; beyond it the
second (docs/service.md, "The runs list at a lab's scale"). The count, read first, tells which.
"""


def _filters(*, status: str | None, system: str | None, tag: str | None, q: str | None,
             config_hash: str | None = None, kind: str | None = None, many: bool = False) -> list[ColumnElement]:
    """The listing's filters; ``many``: the search as each job's check (the jobs read in the page's order)."""
    clauses: list[ColumnElement] = []
    if kind:
        clauses.append(Job.kind == kind)
    if config_hash:
        clauses.append(Job.config_hash == config_hash)
    if status:
        clauses.append(Job.status == status)
    if system in PRESETS:  # a preset's own jobs, not those of a saved system based on it
        clauses.append(Job.system == system)  # each job's tags looked up by its key, not every tag scanned
        clauses.append(~exists().where(JobTag.job_id == Job.id, JobTag.tag.startswith(SAVED_SYSTEM_TAG_PREFIX)))
    elif system:  # a saved system's jobs carry its tag
        clauses.append(Job.id.in_(select(JobTag.job_id).where(JobTag.tag == f"{SAVED_SYSTEM_TAG_PREFIX}{system}")))
    if tag:
        clauses.append(Job.id.in_(select(JobTag.job_id).where(JobTag.tag == tag)))
    if q:
        pattern = f"%{_escape_like(q.lower())}%"
        if SEARCH_SEPARATOR not in q:  # found in the joined text exactly where in a name, notes or tag (search_text)
            clauses.append(exists().where(JobSearch.job_id == Job.id, _found(q)) if many
                           else Job.id.in_(select(JobSearch.job_id).where(_found(q))))
        else:  # text of several lines: only notes hold it
            clauses.append(func.lower(Job.notes).like(pattern, escape="\\"))
    return clauses


LISTED = (Job.id, Job.name, Job.tags, Job.notes, Job.system, cast(Job.config, Text).label("config_json"),
          Job.config_hash, Job.status, Job.progress, Job.attempts, Job.error, Job.requeue_reason, Job.created_at,
          Job.started_at, Job.finished_at, Job.version, Job.study_id, Job.trial_id, Job.kind, Job.stopped,
          Job.compiling, Job.compile_s)
"""The columns a listing shows: no ORM objects, and the configuration as its stored JSON text.

orjson reads that text several times faster than the JSON type's ``json.loads`` (PostgreSQL's
driver would parse it itself, hence the cast); the worker's lease and heartbeat are not read.
"""


def _config(text: str) -> dict[str, Any]:
    try:
        return orjson.loads(text)
    except orjson.JSONDecodeError:  # what only the standard library reads (NaN): never written by the service
        return json.loads(text)


def _found(q: str) -> ColumnElement[bool]:
    """The search rows that hold ``q`` (one line), in any case: their text is stored lowered (:func:`search_text`)."""
    return JobSearch.text.like(f"%{_escape_like(q.lower())}%", escape="\\")


def _count(clauses: list[ColumnElement[bool]], q: str | None, only_q: bool) -> Select:
    """The count of the listing; of the search rows alone when ``q`` is its only filter (every job has one)."""
    if only_q and q and SEARCH_SEPARATOR not in q:
        return select(func.count()).select_from(JobSearch).where(_found(q))
    return select(func.count()).select_from(Job).where(*clauses)


def list_jobs(
    session: Session, *, status: str | None = None, system: str | None = None, tag: str | None = None,
    q: str | None = None, sort: str = "-created_at", limit: int = 50, cursor: str | None = None,
    config_hash: str | None = None, kind: str | None = None,
) -> tuple[list[dict[str, Any]], str | None, int]:
    """One page of jobs as :func:`job_dict` shows them, the next page's cursor (None at the end), the total matching.

    ``sort`` as :func:`backend.store.job_order.parse_sort` reads it (BadQuery naming ``sort`` or ``cursor``);
    ``config_hash`` keeps the jobs of one configuration (system, resolved parameters, episodes), ``kind``
    the jobs of one kind (``simulation`` or ``external``).
    """
    order = parse_sort(sort)
    clauses = _filters(status=status, system=system, tag=tag, q=q, config_hash=config_hash, kind=kind)
    only_q = not (status or system or tag or config_hash or kind)
    total = session.scalar(_count(clauses, q, only_q)) or 0
    if q and total > SEARCH_FEW:
        clauses = _filters(status=status, system=system, tag=tag, q=q, config_hash=config_hash, kind=kind, many=True)
    parts = order.parts(select(*LISTED, order.value.label("sort_key")).where(*clauses), cursor)  # checks the cursor
    rows: list[Row] = []
    for part in parts if total else []:  # nothing matches: no page to read
        rows += session.execute(part.limit(limit + 1 - len(rows))).all()
        if len(rows) > limit:
            break
    next_cursor = None
    if len(rows) > limit:
        rows = rows[:limit]
        next_cursor = order.encode(rows[-1].sort_key, rows[-1].id)
    return [job_dict(row, _config(row.config_json)) for row in rows], next_cursor, total

