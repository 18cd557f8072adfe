"""The dispatcher: claims jobs like a local worker and hands their chunks to a Dask cluster.

It holds each job exactly as a worker does (a lease, heartbeats, cancel), but simulates nothing
itself: each chunk (every algorithm over a block of seeds, :func:`mgrao_core.plan_chunks`) becomes
one Dask task keyed ``mgrao-<job>-<attempt>-<chunk>``, and each chunk's runs are stored, in one
conditional transaction, as soon as its future completes. It keeps as many chunks in flight as the
cluster has threads, plus a small margin, claiming another job whenever the ones it holds have no
chunk left to send. Small jobs are claimed in batches, as a local worker claims them, and each
batch runs as one Dask task keyed ``mgrao-batch-<lease>-<first job>`` whose jobs are stored in one
transaction (:func:`backend.execution.dask_tasks.simulate_batch`). Dask workers need no database
access; the numba kernel is loaded once per Dask worker by a plugin (:class:`backend.execution.dask_tasks.WarmUp`).

What it survives, with every episode stored exactly once:

* a Dask worker that dies or freezes: Dask reruns its chunks elsewhere;
* a chunk that kills its worker every time: after Dask's allowed failures the future raises
  ``KilledWorker`` and that job fails with the reason; the others go on;
* the scheduler restarting: lost futures are resubmitted once the dispatcher has reconnected;
* the dispatcher itself dying: its leases lapse, the jobs are re-queued, and whoever claims them
  next resumes from the stored chunks.
"""

from __future__ import annotations

import logging
import os
import socket
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from distributed import Client, Future, KilledWorker, wait

from backend.execution.dask_tasks import PLUGIN_NAME, WarmUp, simulate_batch, simulate_chunk
from backend.execution.failures import Failure, failure
from backend.execution.heartbeats import Heartbeats
from backend.execution.lifecycle import Ended, Lifecycle, Plan
from backend.execution.lifeline import StopEvent, stop_on_signals
from backend.execution.presence import Presence, refresh_interval
from backend.execution.small_jobs import packed, small_spec
from backend.settings import Settings
from backend.store import queue
from backend.store.db import Database
from backend.store.retry import Backoff, HealthClock, OutageLog, Stopping
from mgrao_core import MgraoError

log = logging.getLogger("mgrao.dispatcher")

IN_FLIGHT_MARGIN = 2
"""Chunks in flight beyond the cluster's threads, so that a thread finishing a chunk finds the next."""
CONNECT_TIMEOUT_S = 10.0


@dataclass
class _Chunk:
    index: int
    seeds: tuple[int, ...]
    future: Future | None = None


@dataclass
class _Job:
    claim: queue.Claim
    plan: Plan
    done_seeds: int
    pending: deque[_Chunk]
    running: dict[str, _Chunk] = field(default_factory=dict)
    made: int = 0
    """Chunks made so far (a job with a stopping rule makes each block's when the one before is judged)."""

    def add_chunks(self, chunks: Sequence[tuple[int, ...]]) -> None:
        """Queue chunks to send, each numbered after the ones before (their Dask keys stay unique)."""
        self.pending.extend(_Chunk(self.made + i, chunk) for i, chunk in enumerate(chunks))
        self.made += len(chunks)

    @property
    def progress(self) -> float:
        return self.done_seeds / len(self.plan.spec.seeds)

    def key(self, chunk: _Chunk) -> str:
        return f"mgrao-{self.claim.job_id}-{self.claim.attempt}-{chunk.index}"


@dataclass
class _Batch:
    """Small jobs claimed together and run as one Dask task (:func:`simulate_batch`)."""

    claims: list[queue.Claim]
    plans: dict[int, Plan]
    future: Future | None = None
    fetch_failures: int = 0
    """Completed futures whose results could not be fetched; the batch is sent again up to :data:`FETCHES`."""

    @property
    def key(self) -> str:
        # The lease is new at every claim (an attempt number is not: a hand-back lowers it again), so
        # a batch claimed anew never takes over an old batch's task still running on a Dask worker.
        return f"mgrao-batch-{self.claims[0].lease}-{self.claims[0].job_id}"


FETCHES = 3
"""Times a completed batch's results are fetched before its jobs fail (the batch is sent again between)."""


class Dispatcher:
    """Runs the queue's jobs on a Dask cluster (see the module docstring); tells ``on_ended`` when one ends."""

    def __init__(self, settings: Settings, address: str, *, dispatcher_id: str | None = None,
                 on_ended: Sequence[Ended] = ()) -> None:
        self.settings = settings
        self.address = address
        self.db = Database(settings.database_url, settings.db_busy_timeout_s)
        self.dispatcher_id = dispatcher_id or f"dispatcher:{socket.gethostname()}:{os.getpid()}"
        self.shutdown = StopEvent()  # set by a signal handler
        self.client: Client | None = None
        self.jobs: dict[int, _Job] = {}
        self.batches: dict[str, _Batch] = {}
        self.health = HealthClock()
        self.lifecycle = Lifecycle(self.db, settings, owner_id=self.dispatcher_id, shutdown=self.shutdown,
                                   health=self.health, on_ended=on_ended)
        self.beats = Heartbeats(self.db, heartbeat_s=settings.heartbeat_s, progress_s=settings.progress_s,
                                health=self.health)
        self._threads = (0, 0.0)

    # ---- life cycle ------------------------------------------------------------------------------

    def stop(self, *_: object) -> None:
        """Ask the dispatcher to stop: it cancels its futures and hands its jobs back."""
        self.shutdown.set()

    def install_signal_handlers(self) -> None:
        """Stop cleanly on SIGTERM and SIGINT."""
        stop_on_signals(self.stop)

    def serve_forever(self) -> None:
        """Migrate, connect, then dispatch until :meth:`stop`; database and cluster faults are waited out."""
        try:
            self._persist(lambda: self.db.migrate(create_missing=False), "migrating the database")
        except Stopping:
            return
        self.beats.start()
        presence = Presence(self.db, self.dispatcher_id, kind="dask", interval_s=refresh_interval(self.settings))
        presence.start()
        backoff = Backoff(first=0.5)
        outage = OutageLog(log, f"dispatcher {self.dispatcher_id} dispatching")
        try:
            while not self.shutdown.is_set():
                try:
                    self._ensure_connected()
                    presence.ready()  # connected: every Dask worker has run the kernel warm-up
                    self._drop_lost_jobs()
                    self._fill()
                    self._collect()
                    backoff.reset()
                    outage.succeeded()
                except Stopping:
                    break
                except Exception as error:  # noqa: BLE001 - the dispatcher outlives every fault of one round
                    outage.failed(error)
                    self._disconnect()
                    self.shutdown.wait(backoff.next())
        finally:
            self._hand_back()
            self._disconnect()
            self.beats.close()
            presence.close()
            self.db.dispose()

    # ---- the cluster -----------------------------------------------------------------------------

    def _ensure_connected(self) -> None:
        if self.client is not None and self.client.status == "running":
            return
        self._disconnect()
        log.info("connecting to the Dask scheduler at %s", self.address)
        client = Client(self.address, timeout=CONNECT_TIMEOUT_S)  # the default client: distributed.wait needs one
        client.register_plugin(WarmUp(), name=PLUGIN_NAME)
        self.client = client
        self._threads = (0, 0.0)
        for job in self.jobs.values():  # whatever was in flight on the old connection is gone
            for chunk in sorted(job.running.values(), key=lambda c: c.index, reverse=True):
                chunk.future = None
                job.pending.appendleft(chunk)
            job.running.clear()
        for batch in self.batches.values():
            batch.future = None  # sent again by _fill
        log.info("connected: %s threads", self._cluster_threads())

    def _disconnect(self) -> None:
        client, self.client = self.client, None
        if client is not None:
            try:
                client.close(timeout=5)
            except Exception:  # noqa: BLE001 - a dead scheduler may not answer the goodbye
                log.debug("closing the Dask client failed", exc_info=True)

    def _cluster_threads(self) -> int:
        count, when = self._threads
        if time.monotonic() - when > 5.0:
            assert self.client is not None
            count = sum(self.client.nthreads().values())
            self._threads = (count, time.monotonic())
        return count

    def capacity(self) -> int:
        """Chunks in flight at most: the cluster's threads plus :data:`IN_FLIGHT_MARGIN`."""
        return max(1, self._cluster_threads()) + IN_FLIGHT_MARGIN

    # ---- jobs ------------------------------------------------------------------------------------

    def _persist(self, call: Any, what: str) -> Any:
        return self.lifecycle.persist(call, what)

    def _in_flight(self) -> int:
        return (sum(len(job.running) for job in self.jobs.values())
                + sum(batch.future is not None for batch in self.batches.values()))

    def _fill(self) -> None:
        while not self.shutdown.is_set() and self._in_flight() < self.capacity():
            batch = next((b for b in self.batches.values() if b.future is None), None)
            if batch is not None:
                self._send(batch)
                continue
            job = next((j for j in self.jobs.values() if j.pending), None)
            if job is None:
                if not self._claim():
                    return
                continue
            chunk = job.pending.popleft()
            assert self.client is not None
            chunk.future = self.client.submit(simulate_chunk, job.claim.config, list(chunk.seeds),
                                              self.settings.job_memory_bytes, key=job.key(chunk))
            job.running[job.key(chunk)] = chunk

    def _claim(self) -> bool:
        """Claim the oldest queued job, or a batch of small ones (:func:`queue.claim_batch`); False when none."""
        requeue = self.lifecycle.may_requeue()
        claims = self._persist(lambda: self.lifecycle.claim_batch(requeue=requeue), "claiming jobs")
        if not claims:
            return False
        specs = {claim.job_id: small_spec(self.settings, claim) for claim in claims}
        small = [claim for claim in claims if specs[claim.job_id] is not None]
        for claim in claims:  # a job big in work or in memory runs chunk by chunk, as before
            if specs[claim.job_id] is None:
                self._start(claim)
        if small:
            self._start_batch(small, specs)
        return True

    def _start(self, claim: queue.Claim) -> None:
        log.info("dispatching job %s (attempt %s)", claim.job_id, claim.attempt)
        try:
            plan = self.lifecycle.plan(claim)
        except MgraoError as error:
            self._fail(claim, failure(error))
            return
        job = _Job(claim, plan, plan.done_seeds, deque())
        job.add_chunks(plan.chunks)
        self.jobs[claim.job_id] = job
        self.beats.add(claim)
        self.beats.set_progress(claim.job_id, job.progress)
        if not plan.chunks:
            self._block_done(job)

    def _start_batch(self, claims: list[queue.Claim], specs: dict) -> None:
        """Plan small jobs as a local worker does (:meth:`Lifecycle.plan_batch`) and hold them as batches.

        Each batch is one Dask task whose runs take at most :data:`~backend.execution.small_jobs.BATCH_BYTES`
        at once (:func:`~backend.execution.small_jobs.packed`): a Dask worker holds a task's results
        whole until the dispatcher stores them.
        """
        plans = self.lifecycle.plan_batch(claims, specs)
        held: list[queue.Claim] = []
        for claim in claims:
            plan = plans[claim.job_id]
            if isinstance(plan, BaseException):
                self._fail(claim, failure(plan))
                continue
            held.append(claim)
            self.beats.add(claim)
        for part in packed(held, specs):
            batch = _Batch(part, {claim.job_id: plans[claim.job_id] for claim in part})
            self.batches[batch.key] = batch
            log.info("dispatcher %s runs a batch of %s jobs (%s to %s)", self.dispatcher_id, len(part),
                     part[0].job_id, part[-1].job_id)

    def _send(self, batch: _Batch) -> None:
        assert self.client is not None
        jobs = [(claim.job_id, claim.config, [list(chunk) for chunk in batch.plans[claim.job_id].chunks])
                for claim in batch.claims]
        batch.future = self.client.submit(simulate_batch, jobs, self.settings.job_memory_bytes, key=batch.key,
                                          pure=False)

    def _collect(self) -> None:
        futures = [c.future for job in self.jobs.values() for c in job.running.values() if c.future is not None]
        futures += [batch.future for batch in self.batches.values() if batch.future is not None]
        if not futures:
            self.shutdown.wait(self.settings.poll_s)
            return
        try:
            done, _ = wait(futures, timeout=self.settings.poll_s, return_when="FIRST_COMPLETED")
        except TimeoutError:  # nothing completed within the poll
            return
        for future in done:
            batch = self.batches.get(future.key)
            if batch is not None and batch.future is future:
                self._batch_completed(batch, future)
                continue
            job = next((j for j in self.jobs.values() if future.key in j.running), None)
            if job is not None:
                self._completed(job, job.running[future.key], future)

    def _completed(self, job: _Job, chunk: _Chunk, future: Future) -> None:
        key = job.key(chunk)
        if future.status == "finished":
            runs = future.result()
            future.release()
            del job.running[key]
            rows = queue.run_rows(job.claim.job_id, runs)
            progress = (job.done_seeds + len(chunk.seeds)) / len(job.plan.spec.seeds)
            stored = self.lifecycle.store(job.claim, rows, progress, job.plan)
            if not stored:
                log.info("job %s was cancelled or taken over; its futures are cancelled", job.claim.job_id)
                self._drop(job)
                return
            job.done_seeds += len(chunk.seeds)
            self.beats.set_progress(job.claim.job_id, job.progress)
            if not job.pending and not job.running:
                self._block_done(job)
            return
        if future.status in ("cancelled", "lost"):  # not by us: the scheduler went away
            log.warning("chunk %s was lost (%s); it is sent again", key, future.status)
            del job.running[key]
            chunk.future = None
            job.pending.appendleft(chunk)
            return
        error = future.exception()
        where = f"chunk {chunk.index} (seeds {chunk.seeds[0]}..{chunk.seeds[-1]})"
        if isinstance(error, KilledWorker):
            self._fail(job.claim, Failure(f"{where} killed every Dask worker that ran it: {error}"))
        else:
            self._fail(job.claim, failure(error, where=f"{where} failed: "))
        self._drop(job)

    def _batch_completed(self, batch: _Batch, future: Future) -> None:
        """Store a batch's jobs in one transaction, as a local worker does; a job's error fails that job only.

        The jobs are told they ended once, together (a study advances once per batch).
        """
        if future.status in ("cancelled", "lost"):  # not by us: the scheduler went away
            log.warning("batch %s was lost (%s); it is sent again", batch.key, future.status)
            batch.future = None
            return
        where = f"its batch of {len(batch.claims)} small jobs"
        ending: Failure | None = None
        results: dict[int, list | Failure] = {}
        if future.status == "finished":
            try:
                results = dict(future.result())
            except Exception as error:  # noqa: BLE001 - e.g. the connection went while fetching
                batch.fetch_failures += 1
                if batch.fetch_failures < FETCHES:
                    log.warning("fetching batch %s failed (%s); it is sent again", batch.key, error)
                    batch.future = None
                    return
                ending = failure(error, where=f"fetching {where} failed: ")
            future.release()
        else:
            error = future.exception()
            ending = (Failure(f"{where} killed every Dask worker that ran it: {error}")
                      if isinstance(error, KilledWorker) else failure(error, where=f"{where} failed: "))
        del self.batches[batch.key]
        try:
            completed: list[queue.Completed] = []
            failed: list[tuple[queue.Claim, Failure]] = []
            for claim in batch.claims:
                if self.beats.lost(claim.job_id):  # cancelled or taken over: nothing of it is stored
                    continue
                result = results.get(claim.job_id, ending or Failure(f"job {claim.job_id} is missing from {where}"))
                if isinstance(result, Failure):
                    failed.append((claim, result))
                    continue
                completed.append(batch.plans[claim.job_id].completed(claim, result))
            failed += self.lifecycle.finish_batch(completed)
            for claim, reason in failed:
                log.warning("job %s failed: %s", claim.job_id, reason.message)
                self.lifecycle.fail(claim, reason)
        finally:
            for claim in batch.claims:
                self.beats.remove(claim.job_id)
        self.lifecycle.ended(*(claim.job_id for claim in batch.claims))

    def _block_done(self, job: _Job) -> None:
        """Every chunk planned is stored: finish the job, or judge its block and send the next block's chunks.

        A job without a stopping rule, or whose rule has answered, finishes.
        """
        if job.plan.stopped:
            self._finish(job)
            return
        plan = self.lifecycle.judge_block(job.claim, job.plan)
        if plan is None:
            log.info("job %s was cancelled or taken over", job.claim.job_id)
            self._drop(job)
            return
        job.plan = plan
        job.add_chunks(plan.chunks)
        if not plan.chunks:
            self._finish(job)

    def _finish(self, job: _Job) -> None:
        finished = self.lifecycle.finish(job.claim, job.plan)
        log.info("job %s %s", job.claim.job_id, "succeeded" if finished else "was cancelled or taken over")
        self._drop(job)
        self.lifecycle.ended(job.claim.job_id)

    def _fail(self, claim: queue.Claim, ending: Failure) -> None:
        log.warning("job %s failed: %s", claim.job_id, ending.message)
        self.lifecycle.fail(claim, ending)
        self.lifecycle.ended(claim.job_id)

    def _drop(self, job: _Job) -> None:
        """Forget a job: cancel what it has in flight, stop its heartbeats."""
        futures = [c.future for c in job.running.values() if c.future is not None]
        job.running.clear()
        job.pending.clear()
        if futures and self.client is not None:
            try:
                self.client.cancel(futures)
            except Exception:  # noqa: BLE001 - a lost scheduler has forgotten them anyway
                log.debug("cancelling futures failed", exc_info=True)
        self.beats.remove(job.claim.job_id)
        self.jobs.pop(job.claim.job_id, None)

    def _drop_lost_jobs(self) -> None:
        for batch in [b for b in self.batches.values() if all(self.beats.lost(c.job_id) for c in b.claims)]:
            log.info("every job of batch %s was cancelled or taken over; its future is cancelled", batch.key)
            self._drop_batch(batch)
        for job in [j for j in self.jobs.values() if self.beats.lost(j.claim.job_id)]:
            log.info("job %s was cancelled or taken over; its futures are cancelled", job.claim.job_id)
            self._drop(job)

    def _drop_batch(self, batch: _Batch) -> None:
        """Forget a batch: cancel its future, stop its jobs' heartbeats."""
        self.batches.pop(batch.key, None)
        if batch.future is not None and self.client is not None:
            try:
                self.client.cancel([batch.future])
            except Exception:  # noqa: BLE001 - a lost scheduler has forgotten it anyway
                log.debug("cancelling a batch failed", exc_info=True)
        for claim in batch.claims:
            self.beats.remove(claim.job_id)

    def _hand_back(self) -> None:
        """On a clean stop: every job goes back to the queue, its stored chunks kept."""
        for batch in list(self.batches.values()):
            try:
                queue.release_many(self.db, claims=batch.claims)
            except Exception:  # noqa: BLE001 - their leases will lapse instead
                log.warning("handing back batch %s failed; its leases will lapse", batch.key)
            self._drop_batch(batch)
        for job in list(self.jobs.values()):
            try:
                queue.release(self.db, claim=job.claim)
            except Exception:  # noqa: BLE001 - its lease will lapse instead
                log.warning("handing back job %s failed; its lease will lapse", job.claim.job_id)
            self._drop(job)


def main(settings: Settings | None = None, address: str | None = None, *, on_ended: Sequence[Ended] = ()) -> None:
    """The dispatcher process (``mgrao dispatcher``): see :mod:`backend.processes`."""
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    settings = settings or Settings()
    address = address or settings.dask_address
    if not address:
        raise SystemExit("mgrao dispatcher: give the Dask scheduler's address (--dask or MGRAO_DASK_ADDRESS)")
    dispatcher = Dispatcher(settings, address, on_ended=on_ended)
    dispatcher.install_signal_handlers()
    dispatcher.serve_forever()
