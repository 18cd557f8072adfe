"""Request and response models; their bounds mirror the core library's limits."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, StringConstraints

from mgrao_core import MAX_ALGORITHMS, MAX_EPISODES, MAX_SEEDS, PARAMETERS
from mgrao_core.spec import MAX_SEED_VALUE

MAX_NAME = 200
MAX_TAG = 50
MAX_TAGS = 20
MAX_NOTES = 10_000
MAX_LABEL = 32
MAX_COMPARE_JOBS = 50
MAX_JOB_ID = 2**63 - 1  # SQLite INTEGER is a signed 64-bit integer

Tag = Annotated[str, StringConstraints(strip_whitespace=True, min_length=1, max_length=MAX_TAG)]
Label = Annotated[str, StringConstraints(min_length=1, max_length=MAX_LABEL)]
Seed = Annotated[StrictInt, Field(ge=0, le=MAX_SEED_VALUE)]
SeedCount = Annotated[StrictInt, Field(ge=1, le=MAX_SEEDS)]
SeedList = Annotated[list[Seed], Field(min_length=1, max_length=MAX_SEEDS)]
ParamValue = StrictBool | StrictInt | float | Annotated[str, StringConstraints(max_length=64)] | None
Status = Literal["queued", "running", "succeeded", "failed", "cancelled"]
Sort = Literal["-created_at", "created_at", "name", "-name", "status", "-status"]


class JobCreate(BaseModel):
    """Body of ``POST /api/jobs``: what to run (validated again by the core) and how to label it."""

    model_config = ConfigDict(extra="forbid")

    system: Annotated[str, StringConstraints(min_length=1, max_length=MAX_LABEL)]
    algorithms: Annotated[list[Label], Field(min_length=1, max_length=MAX_ALGORITHMS)] | None = None
    seeds: SeedCount | SeedList = 30
    episodes: Annotated[StrictInt, Field(ge=1, le=MAX_EPISODES)] = 100
    params: Annotated[dict[Annotated[str, StringConstraints(max_length=64)], ParamValue],
                      Field(max_length=len(PARAMETERS))] = Field(default_factory=dict)
    name: Annotated[str, StringConstraints(strip_whitespace=True, max_length=MAX_NAME)] = ""
    tags: Annotated[list[Tag], Field(max_length=MAX_TAGS)] = Field(default_factory=list)
    notes: Annotated[str, StringConstraints(max_length=MAX_NOTES)] = ""


class JobPatch(BaseModel):
    """Body of ``PATCH /api/jobs/{id}``: any of the labels."""

    model_config = ConfigDict(extra="forbid")

    name: Annotated[str, StringConstraints(strip_whitespace=True, max_length=MAX_NAME)] | None = None
    tags: Annotated[list[Tag], Field(max_length=MAX_TAGS)] | None = None
    notes: Annotated[str, StringConstraints(max_length=MAX_NOTES)] | None = None


class JobOut(BaseModel):
    """A job as the API shows it."""

    id: int
    name: str
    tags: list[str]
    notes: str
    system: str
    algorithms: list[str]
    seeds: list[int]
    episodes: int
    params: dict[str, Any]
    config_hash: str
    status: Status
    progress: float
    attempts: int
    error: str | None
    requeue_reason: str | None = None
    """Why the job was last put back in the queue (its worker stopped sending heartbeats), or null."""
    created_at: str
    started_at: str | None
    finished_at: str | None
    duration_s: float | None
    version: str
    study_id: int | None = None
    trial_id: int | None = None
    summaries: dict[str, dict[str, Any]] = {}
    """Per configuration, once the job succeeded (``GET /api/jobs`` and ``GET /api/jobs/{id}``): n_runs,
    final_mean, ci95, pct_from_uniform, pct_ci95, pct_of_max."""


class JobPage(BaseModel):
    """One page of ``GET /api/jobs``."""

    data: list[JobOut]
    next_cursor: str | None
    count: int


class Health(BaseModel):
    """``GET /api/health``."""

    status: str
    version: str
    database: str
    queued: int | None
    """Jobs queued; null when the database cannot be read (a 503)."""
    running: int | None
    """Jobs running; null when the database cannot be read (a 503)."""
    workers: dict[str, int] | None = None
