"""Heartbeats of claimed jobs, on a background thread: alive, their progress, and whether still ours.

A job whose worker compiles the engine for it says so (:meth:`Heartbeats.compiling`) from the next beat on,
until the compile is done, and adds the seconds it took to the job's ``compile_s``.

A worker holds one claimed job at a time, the dispatcher several. For each, the thread writes the
heartbeat every ``heartbeat_s`` and the progress at most every ``progress_s`` (one conditional
update each); when an update matches no row the job was cancelled or taken over, and
:meth:`Heartbeats.lost` says so from then on. A failing database never stops the thread: the next
beat retries.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from backend.store import queue
from backend.store.db import Database
from backend.store.models import utcnow
from backend.store.retry import HealthClock, OutageLog

if TYPE_CHECKING:
    from mgrao_core.compiling import Compiling

log = logging.getLogger("mgrao.heartbeats")


@dataclass
class _Beat:
    claim: queue.Claim
    progress: float = 0.0
    written: float = -1.0
    last: float = field(default_factory=time.monotonic)
    lost: bool = False
    compiling: Any = queue.UNCHANGED  # what to write of a compile under way: a notice, None once done
    compiled_s: float = 0.0  # seconds of compiling not written yet

    @property
    def news(self) -> bool:
        """Something to write beyond the heartbeat: progress, or a compile begun or done."""
        return self.progress != self.written or self.compiling is not queue.UNCHANGED or self.compiled_s > 0


class Heartbeats(threading.Thread):
    """Beats every job :meth:`add`-ed until it is :meth:`remove`-d or :meth:`close` is called."""

    def __init__(self, db: Database, *, heartbeat_s: float, progress_s: float, name: str = "heartbeats",
                 health: HealthClock | None = None) -> None:
        super().__init__(name=name, daemon=True)
        self.db, self.heartbeat_s, self.progress_s = db, heartbeat_s, progress_s
        self.health = health
        self.outage = OutageLog(log, f"{name} of running jobs")
        self._beats: dict[int, _Beat] = {}
        self._lock = threading.Lock()
        self._closed = threading.Event()

    def add(self, claim: queue.Claim) -> None:
        """Start beating ``claim``'s job."""
        with self._lock:
            self._beats[claim.job_id] = _Beat(claim)

    def remove(self, job_id: int) -> None:
        """Stop beating a job (it ended, or is no longer ours)."""
        with self._lock:
            self._beats.pop(job_id, None)

    def set_progress(self, job_id: int, fraction: float) -> None:
        """The job's progress, written at the next beat that may write it."""
        with self._lock:
            if job_id in self._beats:
                self._beats[job_id].progress = fraction

    def compiling(self, job_id: int, notice: Compiling) -> None:
        """The worker compiles the engine for the job (``notice.seconds`` None) or has (its seconds).

        Written now, by the caller's thread (a job as small as a compiled chunk ends before the next beat): the job
        says so while it lasts, and counts the seconds in its ``compile_s``. A write that fails is left to the
        next beat.
        """
        with self._lock:
            beat = self._beats.get(job_id)
            if beat is None or beat.lost:
                return
            if notice.seconds is None:
                beat.compiling = notice.as_dict() | {"since": utcnow().isoformat() + "Z"}
            else:
                beat.compiling = None
                beat.compiled_s += notice.seconds
        self._beat(beat)

    def lost(self, job_id: int) -> bool:
        """Whether a beat found the job no longer ours (cancelled, or re-queued and claimed again)."""
        with self._lock:
            beat = self._beats.get(job_id)
            return beat is not None and beat.lost

    def close(self) -> None:
        """End the thread (after its current beat)."""
        self._closed.set()
        if self.is_alive():
            self.join()

    def run(self) -> None:
        """Beat until closed."""
        tick = min(self.heartbeat_s, self.progress_s)
        while not self._closed.wait(tick):
            with self._lock:
                due = [b for b in self._beats.values() if not b.lost and (
                    b.news or time.monotonic() - b.last >= self.heartbeat_s)]
            for beat in due:
                self._beat(beat)

    def _beat(self, beat: _Beat) -> None:
        with self._lock:
            progress = beat.progress if beat.progress != beat.written else None
            compiling, compiled_s = beat.compiling, beat.compiled_s
            beat.compiling, beat.compiled_s = queue.UNCHANGED, 0.0
        try:
            ours = queue.heartbeat(self.db, claim=beat.claim, progress=progress, compiling=compiling,
                                   compiled_s=compiled_s)
        except Exception as error:  # a busy database must not stop the beats; the next one retries
            with self._lock:  # what was not written is written by the next beat (unless newer news replaced it)
                if beat.compiling is queue.UNCHANGED:
                    beat.compiling = compiling
                beat.compiled_s += compiled_s
            if self.health is not None:
                self.health.failure()
            self.outage.failed(error)
            return
        if self.health is not None:
            self.health.success()
        self.outage.succeeded()
        if not ours:
            with self._lock:
                beat.lost = True
            return
        with self._lock:
            beat.last = time.monotonic()
            if progress is not None:
                beat.written = progress
