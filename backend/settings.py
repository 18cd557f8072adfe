"""Service settings, read from ``MGRAO_*`` environment variables (pydantic-settings)."""

from __future__ import annotations

import os
from functools import lru_cache
from typing import Annotated

from pydantic import Field, field_validator, model_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

from mgrao_core.budget import MAX_CHUNK_BYTES


class Settings(BaseSettings):
    """Everything the API and the workers can be configured with."""

    model_config = SettingsConfigDict(env_prefix="MGRAO_", extra="ignore")

    database_url: str = "sqlite:///./mgrao.db"
    workers: int = Field(1, ge=0, le=64, description="Local worker processes started by `mgrao serve`.")
    api_token: str | None = Field(None, description="Bearer token for mutating routes; unset = auth off.")
    protect_reads: bool = Field(
        False, description="Reads need the bearer token too: every /api route but a detail-free /api/health, "
                           "/openapi.json and /docs (needs MGRAO_API_TOKEN).")
    stale_after_s: float = Field(60.0, gt=0, description="Heartbeat age after which a running job is re-queued.")
    heartbeat_s: float = Field(5.0, gt=0, description="Seconds between a worker's heartbeats.")
    progress_s: float = Field(1.0, gt=0, description="Smallest interval between progress writes.")
    poll_s: float = Field(0.25, gt=0, description="Idle worker's polling interval for new jobs.")
    batch_jobs: int = Field(64, ge=1, le=1000,
                            description="Small jobs a worker claims, runs and stores at once (1: one at a time).")
    small_job_work: int = Field(200_000, ge=0, le=10**12,
                                description="Atomic tasks (seeds x algorithms x episodes x parents x types per "
                                            "composite) up to which a job is small, and claimed in batches.")
    max_attempts: int = Field(3, ge=1, le=100, description="Claims of a job before a lost worker fails it.")
    max_body_bytes: int = Field(65536, ge=1024, description="Largest accepted request body (413 beyond).")
    job_memory_mib: int = Field(
        MAX_CHUNK_BYTES // 1024**2, ge=16, le=1024**2,
        description="Memory a worker may use for one chunk of a job, above its baseline (422 for a job "
                    "whose single seed needs more).",
    )
    db_busy_timeout_s: float = Field(
        30.0, gt=0, le=3600,
        description="How long a database call waits for another process's write lock before answering 503.",
    )
    min_free_mib: float = Field(
        16.0, ge=0, le=1024**2,
        description="Free space the SQLite database's disk must keep for the results of accepted jobs: below "
                    "it /api/health answers 503 and new jobs and studies are refused with 503 (0 = no check).",
    )
    study_poll_s: float = Field(2.0, gt=0, le=3600,
                                description="How often the API advances running studies (their trials also "
                                            "advance them as they end).")
    stats_workers: int = Field(
        default_factory=lambda: max(1, (os.cpu_count() or 1) // 2), ge=1, le=64,
        description="Comparison statistics (GET /api/compare/statistics and /sample-efficiency) computed at once, in "
                    "threads of their own (default: half the cores, at least 1).")
    stats_queue: int = Field(
        4, ge=0, le=1000, description="Comparison statistics waiting for one of those threads at most: a request for "
                                      "one more is answered 503 with Retry-After at once.")
    stats_wait_s: float = Field(
        15.0, gt=0, le=3600, description="Longest a comparison statistics request waits for its turn: then it is "
                                         "answered 503 with Retry-After.")
    stats_retry_after_s: int = Field(
        10, ge=1, le=3600, description="The Retry-After, in seconds, of a comparison statistics request refused "
                                       "because the statistics are busy.")
    dask_address: str | None = Field(
        None, description="The Dask scheduler `mgrao dispatcher` sends chunks to, e.g. tcp://scheduler:8786.")
    host: str = "127.0.0.1"

    @model_validator(mode="after")
    def _heartbeats_within_the_stale_period(self) -> Settings:
        if self.stale_after_s < 2 * self.heartbeat_s:
            raise ValueError(
                f"MGRAO_STALE_AFTER_S ({self.stale_after_s:g}) must be at least twice MGRAO_HEARTBEAT_S "
                f"({self.heartbeat_s:g}), or live jobs would be re-queued between two heartbeats"
            )
        return self

    @model_validator(mode="after")
    def _protected_reads_need_a_token(self) -> Settings:
        if self.protect_reads and not self.api_token:
            raise ValueError(
                "MGRAO_PROTECT_READS=true needs MGRAO_API_TOKEN: set the token that reads and writes must send "
                "(Authorization: Bearer <token>), or unset MGRAO_PROTECT_READS"
            )
        return self

    @property
    def job_memory_bytes(self) -> int:
        """:attr:`job_memory_mib` in bytes."""
        return self.job_memory_mib * 1024**2

    @property
    def min_free_bytes(self) -> int:
        """:attr:`min_free_mib` in bytes."""
        return int(self.min_free_mib * 1024**2)
    port: int = Field(8000, ge=0, le=65535)
    allowed_hosts: Annotated[list[str], NoDecode] = Field(
        ["127.0.0.1", "localhost"], min_length=1,
        description="Host header names the service answers to (any port), comma-separated; '*' = any.",
    )

    @field_validator("allowed_hosts", mode="before")
    @classmethod
    def _split_hosts(cls, value: object) -> object:
        """``MGRAO_ALLOWED_HOSTS=a,b`` (or a list) as a list of non-empty names."""
        items = value.split(",") if isinstance(value, str) else value
        if isinstance(items, list | tuple):
            items = [str(item).strip() for item in items if str(item).strip()]
        return items


@lru_cache
def get_settings() -> Settings:
    """The settings of this process (read once from the environment)."""
    return Settings()
