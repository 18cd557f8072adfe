"""Studies in the database: made, advanced trial by trial, cancelled, re-run and read.

A study's trials are ordinary jobs (one per system of the base), linked by ``Job.trial_id``; they
run on local workers or the Dask dispatcher like any job. :func:`advance` moves a study on: it
reads the trials whose jobs ended, computes their objectives from the stored runs, then, in one
write transaction holding the study, records them and makes new trials up to the in-flight cap.
Anyone may call it at any time, as often as they like: the API when a study is made, a worker or
the dispatcher when one of its jobs ends, and the API's :class:`StudyDriver` every few seconds (so a
study resumes after any restart). A trial's number is unique per study, so a grid's cell is made
exactly once whoever advances it; a job re-run after a lost worker is still the same trial.

Trial states: ``pending`` (no job yet: waiting for a place in flight), ``queued``, ``running``,
``succeeded``, ``failed``, ``cancelled``.
"""

from __future__ import annotations

import functools
import logging
import math
import threading
import time
from collections import defaultdict
from collections.abc import Sequence
from typing import Any

import orjson
from sqlalchemy import bindparam, delete, func, insert, or_, select, update
from sqlalchemy.orm import Session

import mgrao_core
from backend import wakeup
from backend.errors import Conflict, NotFound
from backend.services import saved_systems
from backend.store import crud
from backend.store import summaries as job_results
from backend.store.db import Database
from backend.store.models import (
    CANCELLED,
    FAILED,
    QUEUED,
    RUNNING,
    STUDY_FINISHED,
    STUDY_RUNNING,
    SUCCEEDED,
    Job,
    Study,
    Trial,
    utcnow,
)
from backend.store.retry import OutageLog
from mgrao_core import ConfigError
from mgrao_core.search import StudyPlan, evaluate, make_plan

log = logging.getLogger("mgrao.studies")

PENDING = "pending"
OPEN = (PENDING, QUEUED, RUNNING)
ENDED = (SUCCEEDED, FAILED, CANCELLED)


def plan_of(study: Study) -> StudyPlan:
    """The study's validated definition (validated once per definition and process: a definition never changes)."""
    return _plan(orjson.dumps(study.definition, option=orjson.OPT_SORT_KEYS))


@functools.lru_cache(maxsize=64)
def _plan(definition: bytes) -> StudyPlan:
    return make_plan(orjson.loads(definition))


def get_study(session: Session, study_id: int) -> Study:
    """The study, or :class:`NotFound`."""
    study = session.get(Study, study_id)
    if study is None:
        raise NotFound(f"study {study_id} not found")
    return study


def create_study(db: Database, *, plan: StudyPlan) -> int:
    """Store a validated study and make its first trials; its id."""
    with db.write() as session:
        study = Study(name=plan.name, method=plan.method, definition=plan.as_dict(), status=STUDY_RUNNING,
                      planned=plan.planned_trials, revision=0, version=mgrao_core.__version__, created_at=utcnow())
        session.add(study)
        session.flush()
        study_id = study.id
    advance(db, study_id)
    return study_id


# ---- advancing -------------------------------------------------------------------------------


def _outcomes(session: Session, study: Study, plan: StudyPlan) -> dict[int, dict[str, Any]]:
    """What became of the open trials' jobs: status, and the objective of those that succeeded."""
    trials = session.execute(select(Trial.id, Trial.params).where(Trial.study_id == study.id,
                                                                 Trial.status.in_((QUEUED, RUNNING)))).all()
    if not trials:
        return {}
    jobs: dict[int, list[Any]] = defaultdict(list)
    for row in session.execute(select(Job.id, Job.trial_id, Job.system, Job.tags, Job.status, Job.error)
                               .where(Job.trial_id.in_([t.id for t in trials]))):
        jobs[row.trial_id].append(row)
    succeeded = [j.id for trial in trials for j in jobs[trial.id] if j.status == SUCCEEDED]
    stored = job_results.config_summaries(session, succeeded)  # written when each job succeeded
    outcomes = {}
    for trial in trials:
        statuses = {j.status for j in jobs[trial.id]}
        if not statuses:  # its jobs were deleted (a trial always gets its jobs in the transaction that makes it)
            outcomes[trial.id] = {"status": FAILED, "error": "its jobs were deleted"}
            continue
        if statuses == {SUCCEEDED}:
            summaries = {system_of(plan, j.system, j.tags): stored.get(j.id) or job_results.compute(session, j.id)
                         for j in jobs[trial.id]}
            value, interval = evaluate(plan, trial.params, summaries)
            runs = sum(s.n_runs for summary in summaries.values() for s in summary.values())
            outcomes[trial.id] = {"status": SUCCEEDED, "value": _finite(value),
                                  "low": _finite(interval[0]) if interval else None,
                                  "high": _finite(interval[1]) if interval else None, "runs": runs}
        elif FAILED in statuses:
            error = next(j.error for j in jobs[trial.id] if j.status == FAILED)
            outcomes[trial.id] = {"status": FAILED, "error": f"a job failed: {error}"}
        elif CANCELLED in statuses:
            outcomes[trial.id] = {"status": CANCELLED, "error": "a job was cancelled"}
        elif RUNNING in statuses:
            outcomes[trial.id] = {"status": RUNNING}
    return outcomes


def _finite(value: float | None) -> float | None:
    return value if value is not None and math.isfinite(value) else None


def _hold(session: Session, study_id: int) -> Study | None:
    """The study, locked for this transaction (PostgreSQL: its row; SQLite: the write transaction)."""
    statement = select(Study).where(Study.id == study_id)
    if session.get_bind().dialect.name != "sqlite":
        statement = statement.with_for_update()
    return session.scalars(statement).first()


def advance(db: Database, study_id: int) -> None:
    """Record the ended trials and make new ones up to the in-flight cap (see the module docstring).

    The slow parts, reading the ended trials' runs and asking TPE for new points, happen before the
    write transaction; it then records what is still true, and makes the suggested trials only if
    no one made trials meanwhile (else whoever did has filled the room).
    """
    with db.session() as session:
        study = session.get(Study, study_id)
        if study is None or study.status != STUDY_RUNNING:
            return
        plan = plan_of(study)
        outcomes = _outcomes(session, study, plan)
        made, suggestions = _suggestions(session, study, plan, outcomes)
    with db.write() as session:
        study = _hold(session, study_id)
        if study is None or study.status != STUDY_RUNNING:
            return
        changed = _record_outcomes(session, outcomes)
        for trial_id, outcome in outcomes.items():
            if outcome["status"] not in (FAILED, CANCELLED):
                continue
            values = dict(outcome) | {"finished_at": utcnow()}
            result = session.execute(update(Trial).where(Trial.id == trial_id, Trial.status.in_((QUEUED, RUNNING)))
                                     .values(**values).execution_options(synchronize_session=False))
            changed |= result.rowcount == 1
            if result.rowcount == 1:
                # a trial over several systems that lost one job: its other jobs have nothing to add
                session.execute(update(Job).where(Job.trial_id == trial_id, Job.status.in_((QUEUED, RUNNING)))
                                .values(status=CANCELLED, lease=None, finished_at=utcnow()))
        submitted = _fill(session, study, plan, made, suggestions)
        changed |= submitted
        open_trials = session.scalar(select(func.count()).select_from(Trial).where(
            Trial.study_id == study_id, Trial.status.in_(OPEN))) or 0
        if open_trials == 0 and _made(session, study_id) >= study.planned:
            study.status, study.finished_at = STUDY_FINISHED, utcnow()
            changed = True
        if changed:
            _update_best(session, study, plan)
            study.revision += 1
    if submitted:  # committed: idle local workers claim the new trials' jobs now, not at their next poll
        wakeup.wake_workers()


_SUCCEEDED_TRIAL = update(Trial.__table__).where(
    Trial.__table__.c.id == bindparam("trial"),
    or_(Trial.__table__.c.status == QUEUED, Trial.__table__.c.status == RUNNING)).values(
    status=SUCCEEDED, value=bindparam("b_value"), low=bindparam("b_low"), high=bindparam("b_high"),
    runs=bindparam("b_runs"), finished_at=bindparam("b_finished_at"))


def _record_outcomes(session: Session, outcomes: dict[int, dict[str, Any]]) -> bool:
    """Record the trials that succeeded (one statement run for all) and those now running (one); whether any changed.

    Each row changes only while its trial is still queued or running, exactly as one ``UPDATE`` each
    would; failed and cancelled trials (rare) are recorded one by one by the caller, which also
    cancels their other jobs.
    """
    changed = False
    now = utcnow()
    succeeded = [{"trial": trial_id, "b_value": o["value"], "b_low": o["low"], "b_high": o["high"],
                  "b_runs": o["runs"], "b_finished_at": now}
                 for trial_id, o in outcomes.items() if o["status"] == SUCCEEDED]
    if succeeded:
        result = session.connection().execute(_SUCCEEDED_TRIAL, succeeded)
        sane = session.get_bind().dialect.supports_sane_multi_rowcount
        changed |= result.rowcount > 0 if sane else True
    running = [trial_id for trial_id, o in outcomes.items() if o["status"] == RUNNING]
    if running:
        result = session.execute(update(Trial).where(Trial.id.in_(running), Trial.status == QUEUED)
                                 .values(status=RUNNING).execution_options(synchronize_session=False))
        changed |= result.rowcount > 0
    return changed


def _made(session: Session, study_id: int) -> int:
    return session.scalar(select(func.count()).select_from(Trial).where(Trial.study_id == study_id)) or 0


def _count(session: Session, study_id: int, statuses: tuple[str, ...]) -> int:
    return session.scalar(select(func.count()).select_from(Trial).where(
        Trial.study_id == study_id, Trial.status.in_(statuses))) or 0


def _suggestions(session: Session, study: Study, plan: StudyPlan,
                 outcomes: dict[int, dict[str, Any]]) -> tuple[int, list[dict[str, Any]]]:
    """How many trials exist, and the parameters of the new trials there will be room for."""
    made = _made(session, study.id)
    ending = sum(1 for o in outcomes.values() if o["status"] in ENDED)
    busy = _count(session, study.id, (QUEUED, RUNNING)) - ending + _count(session, study.id, (PENDING,))
    room = min(plan.max_in_flight - busy, study.planned - made)
    if room <= 0:
        return made, []
    finished: list[tuple[dict[str, Any], float]] = []
    running: list[dict[str, Any]] = []
    if plan.method == "tpe":
        ended = {trial_id: o for trial_id, o in outcomes.items() if o["status"] in ENDED}
        for trial_id, params, status, value in session.execute(
                select(Trial.id, Trial.params, Trial.status, Trial.value).where(Trial.study_id == study.id)
                .order_by(Trial.number)):
            if trial_id in ended:
                status, value = ended[trial_id]["status"], ended[trial_id].get("value")
            if status == SUCCEEDED and value is not None:
                finished.append((params, value))
            elif status in OPEN:
                running.append(params)
    return made, plan.suggest(made, room, finished, running)


def _fill(session: Session, study: Study, plan: StudyPlan, made: int, suggestions: list[dict[str, Any]]) -> bool:
    """Give pending trials, then the suggested new trials, their jobs while the in-flight cap allows."""
    room = plan.max_in_flight - _count(session, study.id, (QUEUED, RUNNING))
    if room <= 0:
        return False
    changed = False
    pending = session.scalars(select(Trial).where(Trial.study_id == study.id, Trial.status == PENDING)
                              .order_by(Trial.number).limit(room)).all()
    for trial in pending:
        _submit(session, study, plan, trial)
        room -= 1
        changed = True
    if room <= 0 or _made(session, study.id) != made:  # someone made trials since the suggestions
        return changed
    _make_trials(session, study, plan, list(enumerate(suggestions[:room], start=made)))
    return changed or bool(suggestions[:room])


def _make_trials(session: Session, study: Study, plan: StudyPlan, numbered: list[tuple[int, dict[str, Any]]]) -> None:
    """New trials with their jobs, in a few statements (a batch of suggestions at once); as :func:`_submit` each."""
    if not numbered:
        return
    now = utcnow()
    rows, specs = [], []
    for number, params in numbered:
        try:
            trial_specs = plan.named_specs(params)
        except ConfigError as error:
            rows.append({"study_id": study.id, "number": number, "params": params, "status": FAILED,
                         "error": f"not a valid experiment: {error}", "runs": 0, "created_at": now,
                         "finished_at": now})
            specs.append([])
            continue
        rows.append({"study_id": study.id, "number": number, "params": params, "status": QUEUED, "runs": 0,
                     "created_at": now})
        specs.append(trial_specs)
    ids = list(session.scalars(insert(Trial).returning(Trial.id, sort_by_parameter_order=True), rows))
    name = study.name or "study"
    crud.create_jobs(session, jobs=[
        {"spec": spec, "name": f"{name} #{number}", "tags": job_tags(study, plan, system), "study_id": study.id,
         "trial_id": trial_id, "until": plan.until}
        for trial_id, (number, _), trial_specs in zip(ids, numbered, specs, strict=True)
        for system, spec in trial_specs])


def job_tags(study: Study, plan: StudyPlan, system: str) -> list[str]:
    """A trial job's tags: its study's, and for a saved system of the base its name (as a job of it has)."""
    return [f"study-{study.id}", *([saved_systems.tag(system)] if system in plan.variants else [])]


def system_of(plan: StudyPlan, preset: str, tags: Sequence[str] | None) -> str:
    """Which of the base's systems a trial's job ran: the saved system its tag names, else its preset."""
    return next((name for name in saved_systems.tagged(tags) if name in plan.variants), preset)


def _submit(session: Session, study: Study, plan: StudyPlan, trial: Trial) -> None:
    """The trial's jobs, one per system (or its failure, when its parameters make no valid experiment)."""
    try:
        specs = plan.named_specs(trial.params)
    except ConfigError as error:
        trial.status, trial.error, trial.finished_at = FAILED, f"not a valid experiment: {error}", utcnow()
        return
    done = {system_of(plan, j.system, j.tags) for j in session.execute(
        select(Job.system, Job.tags).where(Job.trial_id == trial.id, Job.status == SUCCEEDED))}
    for system, spec in specs:
        if system in done:  # re-run after a failure elsewhere: the system that succeeded stands
            continue
        crud.create_job(session, spec=spec, name=f"{study.name or 'study'} #{trial.number}",
                        tags=job_tags(study, plan, system), study_id=study.id, trial_id=trial.id, until=plan.until)
    trial.status, trial.error = QUEUED, None


def _update_best(session: Session, study: Study, plan: StudyPlan) -> None:
    order = Trial.value.desc() if plan.objective.direction == "maximize" else Trial.value.asc()
    best = session.execute(select(Trial.number, Trial.value).where(
        Trial.study_id == study.id, Trial.status == SUCCEEDED, Trial.value.is_not(None))
        .order_by(order, Trial.number).limit(1)).first()
    study.best_trial, study.best_value = (best.number, best.value) if best else (None, None)


def advance_for_jobs(db: Database, job_ids: Sequence[int]) -> None:
    """Advance the studies of jobs that ended, each study once however many of its jobs ended."""
    with db.session() as session:
        study_ids = sorted(set(session.scalars(select(Job.study_id).where(Job.id.in_(list(job_ids)),
                                                                          Job.study_id.is_not(None)))))
    for study_id in study_ids:
        advance(db, study_id)


def advance_after(db: Database, job_ids: Sequence[int]) -> None:
    """Advance the studies of jobs that just ended; a failure here is left to the :class:`StudyDriver`."""
    try:
        advance_for_jobs(db, job_ids)
    except Exception:  # noqa: BLE001 - the driver advances the study on its next round
        log.warning("advancing the studies of jobs %s failed; the study driver will", list(job_ids), exc_info=True)


def hand_over_or_advance(db: Database, job_ids: Sequence[int]) -> None:
    """Hand the studies of jobs that just ended to the API's :class:`StudyDriver`, or advance them here.

    Under ``mgrao serve`` (a wake-up directory, :mod:`backend.wakeup`) the job ids go to the driver, which advances
    their studies on the API's core while this process runs its next jobs; when no driver takes them (none
    listening, its buffer full) they advance here, as :func:`advance_after`. A hand-over lost afterwards (the API
    killed) only delays: the driver advances every running study every ``MGRAO_STUDY_POLL_S``, after any restart.
    """
    payload = ",".join(str(job_id) for job_id in job_ids).encode()
    if job_ids and len(payload) < 60_000 and wakeup.send(wakeup.STUDIES, payload):
        return
    advance_after(db, job_ids)


def advance_study_quietly(db: Database, study_id: int) -> None:
    """:func:`advance`, leaving a failure to the :class:`StudyDriver`."""
    try:
        advance(db, study_id)
    except Exception:  # noqa: BLE001 - the driver advances the study on its next round
        log.warning("advancing study %s failed; the study driver will", study_id, exc_info=True)


def running_studies(db: Database) -> list[int]:
    """The ids of the studies still running."""
    with db.session() as session:
        return list(session.scalars(select(Study.id).where(Study.status == STUDY_RUNNING).order_by(Study.id)))


# ---- cancel, re-run, delete ------------------------------------------------------------------


def cancel_study(db: Database, *, study_id: int) -> None:
    """Cancel a running study: its open trials and their queued or running jobs, in one transaction."""
    with db.write() as session:
        study = _hold(session, study_id)
        if study is None:
            raise NotFound(f"study {study_id} not found")
        if study.status != STUDY_RUNNING:
            raise Conflict(f"study {study_id} is {study.status}: only a running study can be cancelled")
        now = utcnow()
        session.execute(update(Job).where(Job.study_id == study_id, Job.status.in_((QUEUED, RUNNING)))
                        .values(status=CANCELLED, lease=None, finished_at=now))
        session.execute(update(Trial).where(Trial.study_id == study_id, Trial.status.in_(OPEN))
                        .values(status=CANCELLED, error="the study was cancelled", finished_at=now))
        study.status, study.finished_at = CANCELLED, now
        study.revision += 1


def rerun_failed(db: Database, *, study_id: int) -> int:
    """Give every failed or cancelled trial a new go (new jobs, same parameters, same number); how many.

    The study runs again if it had ended. No cell is duplicated: a trial keeps its number, and its
    old jobs stay listed but no longer count for it.
    """
    with db.write() as session:
        study = _hold(session, study_id)
        if study is None:
            raise NotFound(f"study {study_id} not found")
        holes = list(session.scalars(select(Trial.id).where(Trial.study_id == study_id,
                                                            Trial.status.in_((FAILED, CANCELLED)))))
        if holes:
            session.execute(update(Job).where(Job.trial_id.in_(holes), Job.status.in_((FAILED, CANCELLED)))
                            .values(trial_id=None))
            session.execute(update(Trial).where(Trial.id.in_(holes)).values(
                status=PENDING, value=None, low=None, high=None, error=None, runs=0, finished_at=None))
            study.status, study.finished_at = STUDY_RUNNING, None
            study.revision += 1
    if holes:
        advance(db, study_id)
    return len(holes)


def delete_study(db: Database, *, study_id: int) -> None:
    """Delete a study with its trials and their jobs (409 while one of its jobs runs)."""
    with db.write() as session:
        study = _hold(session, study_id)
        if study is None:
            raise NotFound(f"study {study_id} not found")
        running = session.scalar(select(func.count()).select_from(Job).where(Job.study_id == study_id,
                                                                           Job.status == RUNNING)) or 0
        if running:
            raise Conflict(f"study {study_id} has {running} running jobs: cancel it first")
        session.execute(delete(Job).where(Job.study_id == study_id))
        session.execute(delete(Study).where(Study.id == study_id))


# ---- reads -----------------------------------------------------------------------------------


def study_dict(study: Study, counts: dict[str, int] | None = None) -> dict[str, Any]:
    """A study as the API lists it."""
    return {
        "id": study.id, "name": study.name, "method": study.method, "status": study.status,
        "planned": study.planned, "trials": counts or {}, "best_trial": study.best_trial,
        "best_value": study.best_value, "objective": study.definition["objective"],
        "space": study.definition["space"], "created_at": crud.iso(study.created_at),
        "finished_at": crud.iso(study.finished_at), "revision": study.revision, "version": study.version,
    }


def trial_counts(session: Session, study_ids: Sequence[int]) -> dict[int, dict[str, int]]:
    """Trials per status of each study."""
    counts: dict[int, dict[str, int]] = {sid: {} for sid in study_ids}
    for study_id, status, count in session.execute(
            select(Trial.study_id, Trial.status, func.count()).where(Trial.study_id.in_(list(study_ids)))
            .group_by(Trial.study_id, Trial.status)):
        counts[study_id][status] = count
    return counts


def study_detail(session: Session, study_id: int, *, trials: bool = True) -> dict[str, Any]:
    """``GET /api/studies/{id}``: the study, its definition and (unless ``trials`` is false) every trial."""
    study = get_study(session, study_id)
    if not trials:
        counts = trial_counts(session, [study_id])[study_id]
        return {"study": study_dict(study, counts), "definition": study.definition}
    jobs: dict[int, list[int]] = defaultdict(list)
    at_most: dict[int, list[int]] = defaultdict(list)  # the jobs whose rule stopped at max_seeds, unanswered
    for trial_id, job_id, stopped in session.execute(
            select(Job.trial_id, Job.id, Job.stopped).where(Job.study_id == study_id, Job.trial_id.is_not(None))
            .order_by(Job.id)):
        jobs[trial_id].append(job_id)
        if stopped and stopped.get("reason") == "max_seeds":
            at_most[trial_id].append(job_id)
    rows = session.execute(select(Trial.id, Trial.number, Trial.params, Trial.status, Trial.value, Trial.low,
                                  Trial.high, Trial.error, Trial.runs).where(Trial.study_id == study_id)
                           .order_by(Trial.number)).all()
    listed = [{"number": r.number, "params": r.params, "status": r.status, "value": r.value,
               "ci95": [r.low, r.high] if r.low is not None else None, "error": r.error, "runs": r.runs,
               "job_ids": jobs.get(r.id, []), "max_seeds_jobs": at_most.get(r.id, [])} for r in rows]
    counts: dict[str, int] = defaultdict(int)
    for trial in listed:
        counts[trial["status"]] += 1
    return {"study": study_dict(study, dict(counts)), "definition": study.definition, "trials": listed}


class StudyDriver(threading.Thread):
    """Advances every running study every few seconds, in the API process.

    Studies then move on whatever happened to the processes that would otherwise advance them, and
    resume after a restart.
    """

    def __init__(self, db: Database, period_s: float) -> None:
        super().__init__(name="study-driver", daemon=True)
        self.db, self.period_s = db, period_s
        self.stopping = threading.Event()
        self.listener = wakeup.Listener.open(wakeup.STUDIES)  # jobs that ended, handed over by local workers

    def run(self) -> None:
        """Advance until stopped; a failing database only delays the next round (logged once per outage).

        Every ``period_s`` every running study; in between, as soon as a local worker hands them over
        (:func:`hand_over_or_advance`), the studies of the jobs that ended.
        """
        outage = OutageLog(log, "advancing studies")
        next_round = time.monotonic() + self.period_s
        while not self.stopping.is_set():
            left = next_round - time.monotonic()
            if self.listener is None:
                self.stopping.wait(max(0.0, left))
                messages: list[bytes] = []
            else:
                messages = self.listener.wait(left)
            if self.stopping.is_set():
                break
            try:
                ended = sorted({int(part) for message in messages for part in message.split(b",") if part.strip()})
                if ended:
                    advance_for_jobs(self.db, ended)
                if time.monotonic() >= next_round:
                    next_round = time.monotonic() + self.period_s
                    for study_id in running_studies(self.db):
                        advance(self.db, study_id)
            except Exception as error:  # noqa: BLE001 - the next round retries
                outage.failed(error)
            else:
                outage.succeeded()

    def stop(self) -> None:
        """End the thread after its current round."""
        self.stopping.set()
        if self.listener is not None:
            self.listener.poke()
        if self.is_alive():
            self.join(timeout=30)
        if self.listener is not None:
            self.listener.close()
