"""SQLAlchemy 2.0 models: jobs (which are also the queue), their tags and their runs."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import (
    JSON,
    BigInteger,
    DateTime,
    Float,
    ForeignKey,
    Index,
    Integer,
    LargeBinary,
    String,
    Text,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship

QUEUED, RUNNING, SUCCEEDED, FAILED, CANCELLED = "queued", "running", "succeeded", "failed", "cancelled"
OPEN = "open"
"""An external run still taking batches (``POST /api/external-runs/{id}/close`` makes it ``succeeded``)."""
STATUSES = (QUEUED, RUNNING, SUCCEEDED, FAILED, CANCELLED, OPEN)
SIMULATION, EXTERNAL = "simulation", "external"
KINDS = (SIMULATION, EXTERNAL)
"""What a job is: simulated by the service's workers, or logged from outside (docs/platform.md)."""


def utcnow() -> datetime:
    """The current time, UTC, without tzinfo (what the database stores)."""
    return datetime.now(UTC).replace(tzinfo=None)


MAX_JOB_ID = 2**63 - 1  # SQLite INTEGER is a signed 64-bit integer
NUL = "\x00"
"""The character no stored text holds: PostgreSQL's text and JSON columns cannot store it."""


def has_nul(text: str) -> bool:
    """Whether ``text`` holds the NUL character, which no text that comes in may hold."""
    return NUL in text


ID = BigInteger().with_variant(Integer, "sqlite")
"""64-bit ids; SQLite's INTEGER PRIMARY KEY is 64-bit and must stay INTEGER to be the rowid."""


class Base(DeclarativeBase):
    """Declarative base of the service's tables."""


class Job(Base):
    """A submitted experiment; the queue is this table (status ``queued``)."""

    __tablename__ = "jobs"
    __table_args__ = (
        Index("ix_jobs_status_created", "status", "created_at", "id"),
        Index("ix_jobs_created", "created_at", "id"),
        Index("ix_jobs_name", "name", "id"),
        Index("ix_jobs_system_created", "system", "created_at", "id", "status"),  # status: a count reads no row
        {"sqlite_autoincrement": True},  # a deleted job's id is never reused (migration 0004)
    )

    id: Mapped[int] = mapped_column(ID, primary_key=True)
    name: Mapped[str] = mapped_column(String(200), default="")
    tags: Mapped[list[str]] = mapped_column(JSON, default=list)
    notes: Mapped[str] = mapped_column(Text, default="")
    system: Mapped[str] = mapped_column(String(32))
    config: Mapped[dict[str, Any]] = mapped_column(JSON)
    config_hash: Mapped[str] = mapped_column(String(64), index=True)
    status: Mapped[str] = mapped_column(String(16), default=QUEUED)
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    error: Mapped[str | None] = mapped_column(Text, nullable=True)
    version: Mapped[str] = mapped_column(String(32))
    worker_id: Mapped[str | None] = mapped_column(String(100), nullable=True)
    lease: Mapped[str | None] = mapped_column(String(36), nullable=True)
    heartbeat_at: Mapped[datetime | None] = mapped_column(DateTime, nullable=True)
    created_at: Mapped[datetime] = mapped_column(DateTime, default=utcnow)
    started_at: Mapped[datetime | None] = mapped_column(DateTime, nullable=True)
    finished_at: Mapped[datetime | None] = mapped_column(DateTime, nullable=True)
    study_id: Mapped[int | None] = mapped_column(ID, ForeignKey("studies.id", ondelete="CASCADE"), nullable=True,
                                                 index=True)
    trial_id: Mapped[int | None] = mapped_column(ID, ForeignKey("trials.id", ondelete="SET NULL"), nullable=True,
                                                 index=True)
    requeue_reason: Mapped[str | None] = mapped_column(Text, nullable=True)
    """Why the job was last put back in the queue (a lost worker, a database outage), or None."""
    kind: Mapped[str] = mapped_column(String(16), default=SIMULATION, server_default=SIMULATION)
    """:data:`SIMULATION` (run by workers) or :data:`EXTERNAL` (logged via ``/api/external-runs``, never claimed)."""
    work: Mapped[int | None] = mapped_column(BigInteger, nullable=True)
    """The atomic tasks the job simulates (``ExperimentSpec.work``): small jobs are claimed in batches.

    None for jobs stored before migration 0010: those are claimed one at a time."""

    stopped: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    """A job with a stopping rule (``config["until"]``): the rule's last verdict and every block's (migration 0014)."""
    compiling: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    """While its worker compiles the engine for it: what (``mgrao_core.compiling.Compiling``) and since when."""
    compile_s: Mapped[float | None] = mapped_column(Float, nullable=True)
    """Seconds its workers spent compiling the engine for it; None: none (migration 0018)."""

    tag_rows: Mapped[list[JobTag]] = relationship(cascade="all, delete-orphan", passive_deletes=True)
    search_row: Mapped[JobSearch | None] = relationship(cascade="all, delete-orphan", passive_deletes=True)


SEARCH_SEPARATOR = "\n"
"""Between the name, the notes and each tag in :attr:`JobSearch.text`: no name or tag holds it."""


class JobSearch(Base):
    """What the listing's ``q`` searches in a job, in one narrow row: its name, notes and tags (migration 0019).

    ``text`` is ``name``, ``notes`` and each tag, joined by :data:`SEARCH_SEPARATOR` and lowered by the database's
    ``lower`` (:func:`backend.store.crud.search_text`): a search reads this table, a few tens of bytes a job, instead
    of every job's row and its tags, and lowers nothing but ``q``.
    """

    __tablename__ = "job_search"

    job_id: Mapped[int] = mapped_column(ID, ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    text: Mapped[str] = mapped_column(Text)


class JobTag(Base):
    """One tag of a job (for the ``tag`` filter)."""

    __tablename__ = "job_tags"

    job_id: Mapped[int] = mapped_column(ID, ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    tag: Mapped[str] = mapped_column(String(50), primary_key=True, index=True)


RUN_READ_BATCH = 16
"""Runs fetched at a time where a job's runs are streamed (each holds a seed's utilities and weights)."""


SAVED_SYSTEM_TAG_PREFIX = "system:"
"""The tag a job of a saved system carries, before its name (``system:rush-hour``): the job's ``system`` is the base."""


def saved_system_of(tags: Any) -> str | None:
    """The saved system a job of these tags ran (its first tag ``system:<name>``), or None for a preset's job."""
    return next((t.removeprefix(SAVED_SYSTEM_TAG_PREFIX) for t in tags or () if t.startswith(SAVED_SYSTEM_TAG_PREFIX)),
                None)


class Run(Base):
    """One (algorithm, seed) run of a job: every episode utility and the final weights, within stated bounds.

    ``utilities`` holds the run's episodes as little-endian float64 bytes, episode ``e`` at
    offset ``8 e``; one row per (job, algorithm, seed), so a retried write cannot duplicate.
    What a run keeps of its weights is :mod:`backend.store.run_storage`'s.
    """

    __tablename__ = "runs"
    __table_args__ = (UniqueConstraint("job_id", "algorithm", "seed", name="uq_runs_job_algorithm_seed"),)

    id: Mapped[int] = mapped_column(ID, primary_key=True)
    job_id: Mapped[int] = mapped_column(ID, ForeignKey("jobs.id", ondelete="CASCADE"))
    algorithm: Mapped[str] = mapped_column(String(32))
    seed: Mapped[int] = mapped_column(BigInteger)
    episodes: Mapped[int] = mapped_column(Integer)
    utilities: Mapped[bytes] = mapped_column(LargeBinary)
    combined_weights: Mapped[bytes] = mapped_column(LargeBinary)
    group_weights: Mapped[bytes] = mapped_column(LargeBinary)
    group_shape: Mapped[list[int]] = mapped_column(JSON)
    weights_meta: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True, default=None)
    """What the weights columns keep: ``{"children", "combined_children", "group_children", "means", "group_mean"}``
    (:mod:`backend.store.run_storage`); null for runs stored before migration 0017, which kept every weight."""
    child_means: Mapped[bytes | None] = mapped_column(LargeBinary, nullable=True, default=None)
    """A run of more than 100 children: its weights' mean over every child (combined, then PW where kept)."""
    membership: Mapped[bytes | None] = mapped_column(LargeBinary, nullable=True, default=None)
    """Recorded parent-group memberships (int16) of an algorithm whose groups change; null otherwise."""
    membership_meta: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True, default=None)
    """``{"shape": [children, records, parents], "every": episodes between two records}``."""
    tasks_allocated: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    """Atomic tasks allocated where a task can fail (``mgrao_core.TaskCounts``; 0 where none can: migration 0015)."""
    tasks_failed: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    """Of those, the tasks that failed."""
    tasks_handed_over: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    """Of those, the tasks a neighbouring child completed (``hierarchy``)."""


class ExternalRun(Base):
    """What an external job (``Job.kind`` external) adds to its job: the key it was opened with, if any.

    ``open_key`` (unique) makes opening idempotent: the same key and definition (``definition_digest``)
    answer the same run, so a client that died and starts again resumes its run.
    """

    __tablename__ = "external_runs"

    job_id: Mapped[int] = mapped_column(ID, ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    open_key: Mapped[str | None] = mapped_column(String(64), nullable=True, unique=True)
    definition_digest: Mapped[str] = mapped_column(String(64))


class ExternalBatch(Base):
    """A batch an external run took, by the client's key: a retried batch is recognised and not stored twice."""

    __tablename__ = "external_batches"

    job_id: Mapped[int] = mapped_column(ID, ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    batch_key: Mapped[str] = mapped_column(String(64), primary_key=True)
    digest: Mapped[str] = mapped_column(String(64))
    """sha256 of the batch's content: the same key with other content is refused (409)."""
    value_count: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(DateTime, default=utcnow)


class ExternalPiece(Base):
    """Episodes ``start .. start + count - 1`` of one seed of an external run, until the seed is complete.

    Once a seed's pieces cover every episode they become its :class:`Run` (one blob, as a simulated
    run's) and are deleted, so results and compare read external runs as they read any other.
    """

    __tablename__ = "external_pieces"

    job_id: Mapped[int] = mapped_column(ID, ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    seed: Mapped[int] = mapped_column(BigInteger, primary_key=True)
    start: Mapped[int] = mapped_column(Integer, primary_key=True)
    count: Mapped[int] = mapped_column(Integer)
    utilities: Mapped[bytes] = mapped_column(LargeBinary)


class JobSummary(Base):
    """One configuration's summary of a finished job (``mgrao_core.ConfigSummary``), for sorting and columns."""

    __tablename__ = "job_summaries"
    __table_args__ = (Index("ix_job_summaries_final", "algorithm", "final_mean", "job_id"),
                      Index("ix_job_summaries_pct", "algorithm", "pct_from_uniform", "job_id"),
                      Index("ix_job_summaries_max", "algorithm", "pct_of_max", "job_id"))

    job_id: Mapped[int] = mapped_column(ID, ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    algorithm: Mapped[str] = mapped_column(String(32), primary_key=True)
    n_runs: Mapped[int] = mapped_column(Integer)
    final_mean: Mapped[float | None] = mapped_column(Float, nullable=True)
    final_low: Mapped[float | None] = mapped_column(Float, nullable=True)
    final_high: Mapped[float | None] = mapped_column(Float, nullable=True)
    pct_from_uniform: Mapped[float | None] = mapped_column(Float, nullable=True)
    pct_low: Mapped[float | None] = mapped_column(Float, nullable=True)
    pct_high: Mapped[float | None] = mapped_column(Float, nullable=True)
    pct_of_max: Mapped[float | None] = mapped_column(Float, nullable=True)
    n_paired: Mapped[int | None] = mapped_column(Integer, nullable=True)
    """Seeds its % from uniform stands on (``mgrao_core.ConfigSummary.n_paired``)."""
    n_paired_max: Mapped[int | None] = mapped_column(Integer, nullable=True)
    """Seeds its % of max stands on."""
    tasks_allocated: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    """Its runs' atomic tasks allocated where a task can fail, summed over seeds (migration 0015)."""
    tasks_failed: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    """Its runs' tasks that failed, summed over seeds: ``failure_rate`` is this over ``tasks_allocated``."""
    tasks_handed_over: Mapped[int] = mapped_column(BigInteger, default=0, server_default="0")
    """Its runs' tasks completed by a neighbour, summed over seeds: ``handover_rate``'s numerator."""


STUDY_RUNNING, STUDY_FINISHED = "running", "finished"
STUDY_STATUSES = (STUDY_RUNNING, STUDY_FINISHED, CANCELLED)


class Study(Base):
    """A search over parameters: its validated definition (:class:`mgrao_core.search.StudyPlan`) and state.

    ``revision`` grows with every change of the study or its trials (answers are cached by it).
    """

    __tablename__ = "studies"
    __table_args__ = (Index("ix_studies_created", "created_at", "id"), {"sqlite_autoincrement": True})

    id: Mapped[int] = mapped_column(ID, primary_key=True)
    name: Mapped[str] = mapped_column(String(200), default="")
    method: Mapped[str] = mapped_column(String(16))
    definition: Mapped[dict[str, Any]] = mapped_column(JSON)
    status: Mapped[str] = mapped_column(String(16), default=STUDY_RUNNING, index=True)
    planned: Mapped[int] = mapped_column(Integer)
    best_trial: Mapped[int | None] = mapped_column(Integer, nullable=True)
    best_value: Mapped[float | None] = mapped_column(Float, nullable=True)
    revision: Mapped[int] = mapped_column(Integer, default=0)
    version: Mapped[str] = mapped_column(String(32))
    created_at: Mapped[datetime] = mapped_column(DateTime, default=utcnow)
    finished_at: Mapped[datetime | None] = mapped_column(DateTime, nullable=True)


class Trial(Base):
    """One point of a study: its parameters, its jobs (one per system, ``Job.trial_id``) and its objective.

    ``number`` is the trial's place in the study (a grid's cell); unique per study, so a cell is made
    once however many processes advance the study.
    """

    __tablename__ = "trials"
    __table_args__ = (UniqueConstraint("study_id", "number", name="uq_trials_study_number"),
                      Index("ix_trials_study_status", "study_id", "status"))

    id: Mapped[int] = mapped_column(ID, primary_key=True)
    study_id: Mapped[int] = mapped_column(ID, ForeignKey("studies.id", ondelete="CASCADE"))
    number: Mapped[int] = mapped_column(Integer)
    params: Mapped[dict[str, Any]] = mapped_column(JSON)
    status: Mapped[str] = mapped_column(String(16), default=QUEUED)
    value: Mapped[float | None] = mapped_column(Float, nullable=True)
    low: Mapped[float | None] = mapped_column(Float, nullable=True)
    high: Mapped[float | None] = mapped_column(Float, nullable=True)
    error: Mapped[str | None] = mapped_column(Text, nullable=True)
    runs: Mapped[int] = mapped_column(Integer, default=0)
    created_at: Mapped[datetime] = mapped_column(DateTime, default=utcnow)
    finished_at: Mapped[datetime | None] = mapped_column(DateTime, nullable=True)


WARMING, READY = "warming", "ready"
WORKER_STATES = (WARMING, READY)


class WorkerPresence(Base):
    """A worker process (or the Dask dispatcher) that is alive: ``backend/execution/presence.py`` keeps the row.

    ``state`` is ``warming`` while the process loads or compiles the simulation kernel and ``ready``
    once it can run a job; ``seen_at`` is stamped by the database clock at every refresh
    (:func:`backend.execution.presence.refresh_interval`).
    """

    __tablename__ = "workers"

    worker_id: Mapped[str] = mapped_column(String(200), primary_key=True)
    kind: Mapped[str] = mapped_column(String(16))
    state: Mapped[str] = mapped_column(String(16))
    started_at: Mapped[datetime] = mapped_column(DateTime)
    seen_at: Mapped[datetime] = mapped_column(DateTime, index=True)


class SavedSystem(Base):
    """A researcher's named system: a base preset and its overrides (``/api/systems/saved``)."""

    __tablename__ = "saved_systems"

    id: Mapped[int] = mapped_column(ID, primary_key=True, autoincrement=True)
    name: Mapped[str] = mapped_column(String(32), unique=True)
    description: Mapped[str] = mapped_column(Text, default="")
    base: Mapped[str] = mapped_column(String(32))
    params: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(DateTime, default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(DateTime, default=utcnow)
