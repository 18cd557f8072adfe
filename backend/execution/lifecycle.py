"""One job's way through a process that runs jobs: claimed, planned in chunks, stored, finished or failed, ended.

A local worker (:mod:`backend.execution.worker`) and the Dask dispatcher (:mod:`backend.execution.dispatcher`) differ
only in where a chunk is simulated; both hold their jobs through a :class:`Lifecycle`. Every database
call of it is retried until it goes through (:func:`backend.store.retry.persist`), and an error that
ends a job is turned into its stored message by one mapping (:mod:`backend.execution.failures`).
When a job ends, whatever subscribed to ``on_ended`` is told (the studies: a study advances as
soon as one of its trials' jobs ends); job execution itself knows nothing of what listens.
"""

from __future__ import annotations

import logging
import threading
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TypeVar

from backend.execution.failures import Failure, failure
from backend.settings import Settings
from backend.store import queue, summaries
from backend.store.db import Database
from backend.store.retry import HealthClock, persist
from mgrao_core import ExperimentSpec, MgraoError, plan_chunks, spec_from_dict
from mgrao_core.statistics.sequential import Until, Verdict, judge_first, make_until, next_block, replay, stopped_dict

log = logging.getLogger("mgrao.lifecycle")
T = TypeVar("T")

Ended = Callable[[Database, Sequence[int]], None]
"""Told that jobs ended (succeeded, failed, cancelled or taken over): the database and the jobs' ids (a batch's
jobs are told at once, so that a study advances once per batch)."""


@dataclass(frozen=True)
class Plan:
    """A claimed job's validated configuration and the chunks of seeds it still has to run.

    A job with a stopping rule (``until``) is planned a block at a time: ``chunks`` are the next block's seeds
    not yet stored, ``done_seeds`` the seeds judged, ``verdicts`` the rule's after each block, ``finals`` every
    stored run's final utility (kept up to date by :meth:`Lifecycle.store`); :meth:`Lifecycle.judge_block`
    judges a block once its chunks are stored and plans the next, until :attr:`stopped`.
    """

    spec: ExperimentSpec
    done_seeds: int
    chunks: list[tuple[int, ...]]
    until: Until | None = None
    verdicts: tuple[Verdict, ...] = ()
    finals: dict[str, dict[int, float]] = field(default_factory=dict)

    @property
    def stopped(self) -> bool:
        """Whether the job's rule has answered (or it has none)."""
        return self.until is None or bool(self.verdicts) and self.verdicts[-1].reason is not None

    @property
    def ran_seeds(self) -> tuple[int, ...]:
        """The seeds the finished job runs: every seed, or those its rule judged."""
        return self.spec.seeds if self.until is None else self.spec.seeds[: self.done_seeds]

    @property
    def expected_runs(self) -> int:
        """The runs the finished job stores: every algorithm over every seed it runs."""
        return len(self.ran_seeds) * len(self.spec.algorithms)

    def completed(self, claim: queue.Claim, runs: Sequence) -> queue.Completed:
        """The job's remaining ``runs``, done, as :meth:`Lifecycle.finish_batch` stores them.

        With every run's final utility when the job stores all its runs now, for its summary.
        """
        rows = queue.run_rows(claim.job_id, runs)
        finals = summaries.finals_of_rows(rows) if self.done_seeds == 0 else None
        return queue.Completed(claim, rows, self.expected_runs, finals)


class Lifecycle:
    """Claims, plans, stores, finishes, fails and hands back the jobs of one process (``owner_id``)."""

    def __init__(self, db: Database, settings: Settings, *, owner_id: str, shutdown: threading.Event,
                 health: HealthClock, on_ended: Sequence[Ended] = ()) -> None:
        self.db, self.settings, self.owner_id = db, settings, owner_id
        self.shutdown, self.health = shutdown, health
        self.on_ended = tuple(on_ended)

    def persist(self, call: Callable[[], T], what: str) -> T:
        """``call()``, retried on database errors until it succeeds (see :mod:`backend.store.retry`)."""
        return persist(call, what, self.shutdown, self.health)

    def may_requeue(self) -> bool:
        """Whether stale jobs may be re-queued: the database answered for a whole staleness period."""
        return self.health.steady_for(self.settings.stale_after_s)

    def claim(self, *, requeue: bool) -> queue.Claim | None:
        """Take the oldest queued job (re-queueing stale ones first if ``requeue``), or None; not retried."""
        return queue.claim(self.db, worker_id=self.owner_id, stale_after_s=self.settings.stale_after_s,
                           max_attempts=self.settings.max_attempts, requeue=requeue)

    def claim_batch(self, *, requeue: bool) -> list[queue.Claim]:
        """Take the oldest queued job and, if it is small, the next small ones (:func:`queue.claim_batch`)."""
        return queue.claim_batch(self.db, worker_id=self.owner_id, stale_after_s=self.settings.stale_after_s,
                                 max_attempts=self.settings.max_attempts, requeue=requeue,
                                 small_work=self.settings.small_job_work, limit=self.settings.batch_jobs)

    def plan_batch(self, claims: Sequence[queue.Claim],
                   parsed: Mapping[int, ExperimentSpec | None] | None = None) -> dict[int, Plan | MgraoError]:
        """:meth:`plan` of many jobs, their stored runs read in one query; a job no longer valid maps to its error.

        ``parsed`` holds configurations already validated against the job memory budget (a worker
        parses each claimed job once, to tell whether it is small).
        """
        budget = self.settings.job_memory_bytes
        specs: dict[int, ExperimentSpec | MgraoError] = {}
        for claim in claims:
            known = (parsed or {}).get(claim.job_id)
            if known is not None:
                specs[claim.job_id] = known
                continue
            try:
                specs[claim.job_id] = spec_from_dict(claim.config, memory_budget=budget)
            except MgraoError as error:
                specs[claim.job_id] = error
        wanted = {job_id: len(spec.algorithms) for job_id, spec in specs.items() if isinstance(spec, ExperimentSpec)}

        def read() -> dict[int, set[int]]:
            with self.db.session() as session:
                return queue.stored_seeds_of(session, algorithms=wanted)

        done = self.persist(read, "reading stored runs") if wanted else {}
        plans: dict[int, Plan | MgraoError] = {}
        for job_id, spec in specs.items():
            if isinstance(spec, MgraoError):
                plans[job_id] = spec
                continue
            missing = tuple(seed for seed in spec.seeds if seed not in done.get(job_id, ()))
            plans[job_id] = Plan(spec, len(spec.seeds) - len(missing), plan_chunks(spec, missing, budget=budget))
        return plans

    def finish_batch(self, completed: Sequence[queue.Completed]) -> list[tuple[queue.Claim, Failure]]:
        """Store many completed jobs' runs and mark them succeeded in one transaction (:func:`queue.finish_batch`).

        Returns the jobs found with runs missing, each with its failure, for the caller to fail.
        """
        if not completed:
            return []
        outcome = self.persist(lambda: queue.finish_batch(self.db, completed=completed),
                               f"storing a batch of {len(completed)} jobs")
        log.info("a batch of %s jobs stored: %s", len(completed), dict(Counter(outcome.values())))
        return [(item.claim, failure(RuntimeError(f"job {item.claim.job_id} has runs missing")))
                for item in completed if outcome[item.claim.job_id] == queue.INCOMPLETE]

    def release_many(self, claims: Sequence[queue.Claim]) -> None:
        """Hand jobs back to the queue in one transaction (the process is stopping); their stored runs stay."""
        self.persist(lambda: queue.release_many(self.db, claims=claims), f"handing back {len(claims)} jobs")

    def plan(self, claim: queue.Claim) -> Plan:
        """The job's configuration, validated again, and its seeds not yet stored, in chunks the job budget holds.

        With a stopping rule, the next block's: the stored blocks are judged again first (:func:`replay`), so a
        job resumed after its worker died stops where it would have.

        Raises:
            MgraoError: the stored configuration is no longer valid.
        """
        budget = self.settings.job_memory_bytes
        spec = spec_from_dict(claim.config, memory_budget=budget)
        if claim.config.get("until") is not None:
            until = make_until(claim.config["until"], spec.algorithms)

            def read() -> dict[str, dict[int, float]]:
                with self.db.session() as session:
                    return summaries.finals(session, claim.job_id)

            finals = self.persist(read, "reading stored runs")
            return self._block(Plan(spec, 0, [], until, replay(spec, until, finals), finals))
        done = self.persist(lambda: self.stored_seeds(claim.job_id, len(spec.algorithms)), "reading stored runs")
        missing = tuple(seed for seed in spec.seeds if seed not in done)
        return Plan(spec, len(spec.seeds) - len(missing), plan_chunks(spec, missing, budget=budget))

    def _block(self, plan: Plan) -> Plan:
        """``plan`` with the seeds judged after its verdicts and the next block's missing seeds in chunks."""
        judged = plan.verdicts[-1].seeds if plan.verdicts else 0
        chunks: list[tuple[int, ...]] = []
        if not (plan.verdicts and plan.verdicts[-1].reason is not None):
            block = next_block(plan.spec, plan.until, judged)
            missing = tuple(s for s in block if any(s not in plan.finals.get(a, {}) for a in plan.spec.algorithms))
            chunks = plan_chunks(plan.spec, missing, budget=self.settings.job_memory_bytes) if missing else []
        return replace(plan, done_seeds=judged, chunks=chunks)

    def judge_block(self, claim: queue.Claim, plan: Plan) -> Plan | None:
        """Judge the block whose chunks are stored, store the verdicts, and plan the next block (none: stopped).

        None when the job is no longer ours (cancelled or taken over).
        """
        judged = plan.done_seeds + len(next_block(plan.spec, plan.until, plan.done_seeds))
        verdicts = (*plan.verdicts, judge_first(plan.spec, plan.until, plan.finals, judged))
        stopped = stopped_dict(verdicts, plan.until.as_dict())
        if not self.persist(lambda: queue.record_stopped(self.db, claim=claim, stopped=stopped,
                                                         progress=judged / len(plan.spec.seeds)),
                            f"storing the verdict of job {claim.job_id}"):
            return None
        return self._block(replace(plan, verdicts=verdicts))

    def stored_seeds(self, job_id: int, algorithms: int) -> set[int]:
        """The seeds of which every algorithm's run is stored: a retried job runs only the others."""
        with self.db.session() as session:
            return queue.stored_seeds(session, job_id=job_id, algorithms=algorithms)

    def store(self, claim: queue.Claim, rows: list[dict], progress: float, plan: Plan | None = None) -> bool:
        """Store a chunk's runs (:func:`~backend.store.queue.run_rows`) and the progress; False when not ours.

        With a ``plan`` that has a stopping rule, the runs' final utilities join its ``finals``.
        """
        stored = self.persist(lambda: queue.store_runs(self.db, claim=claim, rows=rows, progress=progress),
                              f"storing runs of job {claim.job_id}")
        if stored and plan is not None and plan.until is not None:
            for algorithm, by_seed in summaries.finals_of_rows(rows).items():
                plan.finals.setdefault(algorithm, {}).update(by_seed)
        return stored

    def finish(self, claim: queue.Claim, plan: Plan) -> bool:
        """Mark the job succeeded (with a rule: why it stopped); False when it was cancelled or taken over meanwhile."""
        ran = {} if plan.until is None else {"stopped": stopped_dict(plan.verdicts, plan.until.as_dict()),
                                             "seeds": plan.ran_seeds}
        return self.persist(lambda: queue.finish(self.db, claim=claim, expected_runs=plan.expected_runs, **ran),
                            f"finishing job {claim.job_id}")

    def fail(self, claim: queue.Claim, error: BaseException | Failure, *, where: str = "") -> None:
        """Mark the job failed, with ``error`` mapped by :func:`failure` (a :class:`Failure` as it is)."""
        ending = error if isinstance(error, Failure) else failure(error, where=where)
        self.persist(lambda: queue.fail(self.db, claim=claim, error=ending.message, discard_runs=ending.discard_runs),
                     f"failing job {claim.job_id}")

    def release(self, claim: queue.Claim) -> None:
        """Hand the job back to the queue (the process is stopping); its stored runs stay."""
        self.persist(lambda: queue.release(self.db, claim=claim), f"handing back job {claim.job_id}")

    def ended(self, *job_ids: int) -> None:
        """Tell every subscriber that the jobs ended; a subscriber's failure is logged, never raised."""
        if not job_ids:
            return
        for subscriber in self.on_ended:
            try:
                subscriber(self.db, job_ids)
            except Exception:  # noqa: BLE001 - a subscriber never stops a process that runs jobs
                log.warning("a subscriber to the end of jobs %s failed", list(job_ids), exc_info=True)
