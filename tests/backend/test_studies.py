"""Studies through the API: every grid cell once, re-run failed, cancel, delete, listings and bad input.

The in-process tests drive real workers with ``run_once`` on real SQLite files and PostgreSQL
databases; the process tests (SIGKILL of a worker, of the whole service) use ``mgrao serve`` and
``mgrao worker``.
"""

from __future__ import annotations

import signal
import time
from collections import Counter

import pytest
from backend_helpers import JSON, TOKEN, Service, drain
from fastapi.testclient import TestClient
from sqlalchemy import func, select

from backend.execution.worker import Worker
from backend.store import queue
from backend.store.db import Database
from backend.store.models import Job, Run, Trial
from mgrao_core import run_experiment
from mgrao_core.search import make_plan


def grid(rows: int = 3, cols: int = 3, **changes) -> dict:
    study = {
        "name": "lr by decay", "method": "grid",
        "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 15},
        "space": {"learning_rate": {"low": 0.05, "high": 0.2, "steps": rows},
                  "trace_decay": {"low": 0.5, "high": 0.9, "steps": cols}},
        "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform", "direction": "maximize"},
        "max_trials": 100, "max_in_flight": 4,
    }
    return study | changes


def submit(client: TestClient, study: dict) -> int:
    response = client.post("/api/studies", json=study)
    assert response.status_code == 202, response.text
    assert response.headers["Location"] == f"/api/studies/{response.json()['study']['id']}"
    return response.json()["study"]["id"]


def detail(client: TestClient, study_id: int) -> dict:
    response = client.get(f"/api/studies/{study_id}")
    assert response.status_code == 200, response.text
    return response.json()


def run_study(client: TestClient, worker: Worker, study_id: int, timeout: float = 120) -> dict:
    """Run queued jobs and advance until the study is no longer running."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        drain(worker)
        answer = detail(client, study_id)
        if answer["study"]["status"] != "running":
            return answer
        time.sleep(0.05)
    raise AssertionError(f"study {study_id} still running: {detail(client, study_id)['study']}")


def assert_each_cell_once(db_url: str, study_id: int, cells: int, runs_per_job: int) -> None:
    db = Database(db_url)
    try:
        with db.session() as session:
            numbers = list(session.scalars(select(Trial.number).where(Trial.study_id == study_id)))
            per_trial = Counter(session.scalars(select(Job.trial_id).where(Job.study_id == study_id,
                                                                           Job.trial_id.is_not(None))))
            runs = dict(session.execute(select(Run.job_id, func.count()).join(Job, Job.id == Run.job_id)
                                        .where(Job.study_id == study_id, Job.trial_id.is_not(None))
                                        .group_by(Run.job_id)).all())
            distinct = session.scalar(select(func.count()).select_from(
                select(Run.job_id, Run.algorithm, Run.seed).join(Job, Job.id == Run.job_id)
                .where(Job.study_id == study_id).distinct().subquery()))
            total = session.scalar(select(func.count()).select_from(Run).join(Job, Job.id == Run.job_id)
                                   .where(Job.study_id == study_id))
    finally:
        db.dispose()
    assert sorted(numbers) == list(range(cells))  # every cell made once
    assert len(per_trial) == cells and set(per_trial.values()) == {1}  # one job each
    assert set(runs.values()) == {runs_per_job}
    assert distinct == total  # no run stored twice


def test_a_grid_study_runs_every_cell_once_and_reads_back(client: TestClient, worker: Worker, db_url: str) -> None:
    study_id = submit(client, grid())
    first = detail(client, study_id)
    assert first["study"]["trials"] == {"queued": 4}  # max_in_flight
    assert first["study"]["planned"] == 9
    done = run_study(client, worker, study_id)
    assert done["study"]["status"] == "finished"
    assert done["study"]["trials"] == {"succeeded": 9}
    assert_each_cell_once(db_url, study_id, 9, runs_per_job=4)

    trials = done["trials"]
    best = max(trials, key=lambda t: t["value"])
    assert (done["study"]["best_trial"], done["study"]["best_value"]) == (best["number"], best["value"])
    plan = make_plan(done["definition"])
    for trial in trials:  # each trial's figure is the core's for its cell
        assert trial["params"] == plan.cell(trial["number"])
        assert trial["ci95"][0] <= trial["value"] <= trial["ci95"][1]
    (spec,) = plan.specs(trials[4]["params"])
    summary = run_experiment(spec).summary()["mgrao-max"]
    assert trials[4]["value"] == pytest.approx(summary.pct_from_uniform, abs=1e-9)

    job = client.get(f"/api/jobs/{trials[4]['job_ids'][0]}").json()  # an ordinary job, linked to its study
    assert (job["study_id"], job["status"], job["name"]) == (study_id, "succeeded", "lr by decay #4")
    assert client.get(f"/api/jobs?tag=study-{study_id}").json()["count"] == 9

    plots = client.get(f"/api/studies/{study_id}/plots").json()
    heatmap = plots["heatmap"]
    assert (heatmap["x"], heatmap["y"]) == ("learning_rate", "trace_decay")
    assert heatmap["count"] == [[1, 1, 1]] * 3
    assert heatmap["mean"][1][2] == pytest.approx(next(t["value"] for t in trials if t["number"] == 7))
    assert plots["history"]["best"][-1] == best["value"]
    assert sorted(plots["importance"]) == ["learning_rate", "trace_decay"]
    assert len(plots["slices"]["learning_rate"]["bins"]["x"]) == 3
    swapped = client.get(f"/api/studies/{study_id}/plots?x=trace_decay&y=learning_rate").json()["heatmap"]
    assert swapped["mean"] == [list(col) for col in zip(*heatmap["mean"], strict=True)]


def test_re_run_failed_fills_the_holes_without_duplicating_a_cell(client: TestClient, worker: Worker,
                                                                  db_url: str) -> None:
    study_id = submit(client, grid(2, 2))
    jobs = {t["number"]: t["job_ids"][0] for t in detail(client, study_id)["trials"]}
    assert client.post(f"/api/jobs/{jobs[1]}/cancel", headers=JSON).status_code == 200
    assert client.delete(f"/api/jobs/{jobs[2]}", headers=JSON).status_code == 204
    done = run_study(client, worker, study_id)
    assert done["study"]["status"] == "finished"
    by_number = {t["number"]: t for t in done["trials"]}
    assert [by_number[n]["status"] for n in range(4)] == ["succeeded", "cancelled", "failed", "succeeded"]
    assert "deleted" in by_number[2]["error"]

    response = client.post(f"/api/studies/{study_id}/rerun-failed", headers=JSON)
    assert response.status_code == 200 and response.json()["rerun"] == 2
    assert response.json()["study"]["status"] == "running"
    done = run_study(client, worker, study_id)
    assert done["study"]["trials"] == {"succeeded": 4}
    assert_each_cell_once(db_url, study_id, 4, runs_per_job=4)
    assert {t["number"]: t["job_ids"][0] for t in done["trials"]}[0] == jobs[0]  # the others kept their jobs
    assert client.post(f"/api/studies/{study_id}/rerun-failed", headers=JSON).json()["rerun"] == 0


def test_cancelling_a_study_cancels_its_queued_and_running_trials(client: TestClient, worker: Worker,
                                                                  db: Database) -> None:
    study_id = submit(client, grid(3, 3, max_in_flight=3))
    assert worker.run_once()  # the trials in flight ran, as one batch of small jobs
    running = queue.claim(db, worker_id="elsewhere", stale_after_s=60, max_attempts=3)
    assert running is not None  # one trial is running elsewhere
    answer = client.post(f"/api/studies/{study_id}/cancel", headers=JSON)
    assert answer.status_code == 200
    assert answer.json()["study"]["status"] == "cancelled"
    statuses = Counter(t["status"] for t in answer.json()["trials"])
    assert statuses == {"succeeded": 3, "cancelled": 3}  # the next three: one running, two queued
    assert not worker.run_once()  # nothing left queued
    with db.session() as session:
        assert session.get(Job, running.job_id).status == "cancelled"
        made = session.scalar(select(func.count()).select_from(Trial).where(Trial.study_id == study_id))
    assert not queue.store_runs(db, claim=running, rows=[], progress=1.0)  # its lease is gone
    time.sleep(0.3)
    assert detail(client, study_id)["study"]["status"] == "cancelled"
    assert len(detail(client, study_id)["trials"]) == made  # no trial made after the cancel
    assert client.post(f"/api/studies/{study_id}/cancel", headers=JSON).status_code == 409


def test_deleting_a_study_deletes_its_jobs_and_waits_for_running_ones(client: TestClient, worker: Worker,
                                                                      db: Database) -> None:
    study_id = submit(client, grid(2, 2, max_in_flight=2))
    running = queue.claim(db, worker_id="elsewhere", stale_after_s=60, max_attempts=3)
    assert running is not None
    conflict = client.delete(f"/api/studies/{study_id}", headers=JSON)
    assert conflict.status_code == 409 and "running" in conflict.json()["detail"]
    client.post(f"/api/studies/{study_id}/cancel", headers=JSON)
    assert client.delete(f"/api/studies/{study_id}", headers=JSON).status_code == 204
    assert client.get(f"/api/studies/{study_id}").status_code == 404
    assert client.get(f"/api/jobs/{running.job_id}").status_code == 404
    assert client.get("/api/jobs").json()["count"] == 0
    assert client.delete(f"/api/studies/{study_id}", headers=JSON).status_code == 404


def test_a_tpe_study_with_a_group_count_dimension(client: TestClient, worker: Worker) -> None:
    study = grid(method="tpe", max_trials=6, max_in_flight=2,
                 space={"learning_rate": {"low": 0.01, "high": 0.5, "log": True},
                        "groups": {"values": [1, 2, 5]}},
                 objective={"configuration": "mgrao-x:1", "metric": "final_mean"})
    study_id = submit(client, study)
    done = run_study(client, worker, study_id)
    assert done["study"]["trials"] == {"succeeded": 6}
    for trial in done["trials"]:
        assert 0.01 <= trial["params"]["learning_rate"] <= 0.5
        job = client.get(f"/api/jobs/{trial['job_ids'][0]}").json()
        assert job["algorithms"][-1] == f"mgrao-{trial['params']['groups']}:1"


def test_a_grid_study_sweeps_the_children_sharing_a_model_beside_the_group_count(client: TestClient,
                                                                                  worker: Worker) -> None:
    # issue 45: y of mgrao-x:y is a dimension beside x (the systems' answer names the configuration they add)
    assert client.get("/api/systems").json()["studies"]["team_label"] == "mgrao-x:y"
    study = grid(base={"system": "multi", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 10},
                 space={"groups": {"values": [1, 5]}, "team_size": {"values": [1, 3]}},
                 objective={"configuration": "mgrao-x:y", "metric": "pct_from_uniform"})
    done = run_study(client, worker, submit(client, study))
    assert done["study"]["trials"] == {"succeeded": 4}
    for trial in done["trials"]:
        job = client.get(f"/api/jobs/{trial['job_ids'][0]}").json()
        label = f"mgrao-{trial['params']['groups']}:{trial['params']['team_size']}"
        assert job["algorithms"][-1] == label
        assert trial["value"] == job["summaries"][label]["pct_from_uniform"]


def test_a_study_over_several_systems_runs_a_job_per_system(client: TestClient, worker: Worker) -> None:
    study = grid(base={"system": ["single", "multi"], "seeds": 2, "episodes": 10},
                 space={"half_saturation": {"values": [0.15, 0.25]}},
                 objective={"metric": "paper_deviation"})
    done = run_study(client, worker, submit(client, study))
    assert done["study"]["trials"] == {"succeeded": 2}
    assert all(len(t["job_ids"]) == 2 for t in done["trials"])
    assert done["study"]["objective"]["direction"] == "minimize"
    assert done["study"]["best_value"] == min(t["value"] for t in done["trials"])


@pytest.mark.parametrize(("change", "loc"), [
    ({"space": {"nope": {"values": [1]}}}, ["body", "space", "nope"]),
    ({"space": {"learning_rate": {"values": []}}}, ["body", "space", "learning_rate", "values"]),
    ({"space": {"learning_rate": {"low": 0.5, "high": 0.1, "steps": 3}}}, ["body", "space", "learning_rate"]),
    ({"space": {"learning_rate": {"low": 0.01, "high": 0.5, "steps": 200},
                "trace_decay": {"low": 0.1, "high": 0.9, "steps": 60}}}, ["body", "space"]),
    ({"objective": {"configuration": "mgrao-5:1", "metric": "final_mean"}}, ["body", "objective", "configuration"]),
    ({"space": {"groups": {"values": [2, 3]}}}, ["body", "space", "groups", "values", 1]),
    ({"space": {"team_size": {"values": [1, 2]}}}, ["body", "space", "team_size", "values", 1]),
    ({"base": {"system": "single", "params": {"n_parents": 0}}}, ["body", "base", "params", "n_parents"]),
])
def test_bad_studies_answer_422_naming_the_field(client: TestClient, change: dict, loc: list) -> None:
    response = client.post("/api/studies", json=grid() | change)
    assert response.status_code == 422, response.text
    (detail_,) = response.json()["detail"]
    assert detail_["loc"] == loc
    assert detail_["msg"].startswith(detail_["field"])
    assert client.get("/api/studies").json()["count"] == 0  # nothing stored


def test_a_body_that_is_not_a_study_answers_422(client: TestClient) -> None:
    assert client.post("/api/studies", json=[1, 2]).status_code == 422
    assert client.post("/api/studies", content=b"{", headers=JSON).status_code == 422


def test_listing_filters_sorts_and_pages(client: TestClient) -> None:
    ids = [submit(client, grid(2, 2, name=name, max_in_flight=1)) for name in ("beta", "alpha", "gamma", "delta")]
    random_id = submit(client, grid(name="epsilon", method="random", max_trials=3, max_in_flight=1,
                                    space={"learning_rate": {"low": 0.01, "high": 0.5}}))
    listing = client.get("/api/studies").json()
    assert listing["count"] == 5
    assert [s["id"] for s in listing["data"]] == [random_id, *reversed(ids)]  # newest first
    assert listing["data"][0]["trials"] == {"queued": 1}

    names, cursor = [], None
    for _ in range(10):  # 5 studies, 2 a page: a cursor that never ends fails below instead of looping forever
        page = client.get("/api/studies", params={"sort": "name", "limit": 2} | ({"cursor": cursor} if cursor else {}))
        assert page.status_code == 200
        names += [s["name"] for s in page.json()["data"]]
        cursor = page.json()["next_cursor"]
        if cursor is None:
            break
    assert cursor is None, f"still a next_cursor after 10 pages: {names}"
    assert names == ["alpha", "beta", "delta", "epsilon", "gamma"]
    assert [s["id"] for s in client.get("/api/studies?method=random").json()["data"]] == [random_id]
    assert [s["name"] for s in client.get("/api/studies?q=MMA").json()["data"]] == ["gamma"]
    assert client.get("/api/studies?status=finished").json()["count"] == 0
    wrong = client.get("/api/studies", params={"sort": "-name", "cursor": cursor or "bm9wZQ"})
    assert wrong.status_code == 422 and wrong.json()["detail"][0]["loc"] == ["query", "cursor"]
    assert client.get("/api/studies?sort=value").status_code == 422


def test_writes_need_the_token_when_one_is_set(auth_client: TestClient) -> None:
    assert auth_client.post("/api/studies", json=grid()).status_code == 401
    created = auth_client.post("/api/studies", json=grid(), headers={"Authorization": f"Bearer {TOKEN}"})
    assert created.status_code == 202
    study_id = created.json()["study"]["id"]
    assert auth_client.get(f"/api/studies/{study_id}").status_code == 200  # reads are open
    assert auth_client.post(f"/api/studies/{study_id}/cancel", headers=JSON).status_code == 401
    assert auth_client.delete(f"/api/studies/{study_id}", headers=JSON).status_code == 401


# ---- real processes --------------------------------------------------------------------------

# trials of about 0.2 s each, so that a kill lands while some are still to be made
PROCESS_STUDY = grid(3, 3, base={"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3,
                                 "episodes": 20000}, max_in_flight=3)


def _status(service: Service, study_id: int) -> dict:
    return service.get(f"/api/studies/{study_id}").json()["study"]


@pytest.mark.slow
def test_a_worker_killed_mid_study_leaves_every_cell_run_once(service: Service, db_url: str) -> None:
    service.env["MGRAO_STUDY_POLL_S"] = "0.3"
    service.start_server(workers=0)
    victim, _other = service.start_worker(), service.start_worker()
    study_id = service.post("/api/studies", json=PROCESS_STUDY).json()["study"]["id"]
    service.wait_for(lambda: _status(service, study_id)["trials"].get("succeeded", 0) >= 1, what="a first trial")
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    service.wait_for(lambda: _status(service, study_id)["status"] == "finished", timeout=240, what="the study")
    assert _status(service, study_id)["trials"] == {"succeeded": 9}
    assert_each_cell_once(db_url, study_id, 9, runs_per_job=6)
    answer = service.get(f"/api/studies/{study_id}").json()
    plan = make_plan(answer["definition"])
    last = answer["trials"][-1]
    (spec,) = plan.specs(last["params"])
    expected = run_experiment(spec).summary()["mgrao-max"].pct_from_uniform
    assert last["value"] == pytest.approx(expected, abs=1e-9)  # the same numbers, whoever ran it


@pytest.mark.slow
def test_a_study_resumes_after_the_whole_service_is_killed(service: Service, db_url: str) -> None:
    service.env["MGRAO_STUDY_POLL_S"] = "0.3"
    service.start_server(workers=1)
    study_id = service.post("/api/studies", json=PROCESS_STUDY).json()["study"]["id"]
    def two_trials() -> bool:
        trials = _status(service, study_id)["trials"]
        if sum(trials.values()) >= 9:
            raise AssertionError(f"every trial was made before the kill: {trials}; the trials are too short")
        return trials.get("succeeded", 0) >= 2

    service.wait_for(two_trials, what="two trials")
    service.kill_server()  # its workers follow it (their lifeline)
    before = _count_trials(db_url, study_id)
    assert before < 9

    service.start_server(workers=2)
    service.wait_for(lambda: _status(service, study_id)["status"] == "finished", timeout=240, what="the study")
    assert _status(service, study_id)["trials"] == {"succeeded": 9}
    assert_each_cell_once(db_url, study_id, 9, runs_per_job=6)


def _count_trials(db_url: str, study_id: int) -> int:
    db = Database(db_url)
    try:
        with db.session() as session:
            return session.scalar(select(func.count()).select_from(Trial).where(Trial.study_id == study_id))
    finally:
        db.dispose()


def test_the_objective_of_a_trial_equals_a_lone_job_of_its_cell(client: TestClient, worker: Worker) -> None:
    done = run_study(client, worker, submit(client, grid(2, 2)))
    trial = done["trials"][1]
    lone = client.post("/api/jobs", json={"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2,
                                          "episodes": 15, "params": trial["params"]}).json()["id"]
    drain(worker)
    def episodes(job_id: int) -> list[str]:  # the rows without their job id
        return [row.split(",", 1)[1] for row in client.get(f"/api/jobs/{job_id}/episodes").text.splitlines()]

    mine, theirs = episodes(trial["job_ids"][0]), episodes(lone)
    assert len(mine) == 1 + 2 * 2 * 15
    assert mine == theirs  # bit for bit: a trial is an ordinary job


def test_a_trial_over_two_systems_that_loses_one_job_reruns_only_that_system(client: TestClient, db: Database,
                                                                            single_worker: Worker) -> None:
    worker = single_worker
    study = grid(base={"system": ["single", "multi"], "seeds": 2, "episodes": 10},
                 space={"half_saturation": {"values": [0.15, 0.25]}}, objective={"metric": "paper_deviation"},
                 max_in_flight=1)
    study_id = submit(client, study)
    single_job, multi_job = detail(client, study_id)["trials"][0]["job_ids"]
    assert worker.run_once()  # trial 0's single job ran
    client.post(f"/api/jobs/{multi_job}/cancel", headers=JSON)
    first = detail(client, study_id)["trials"][0]
    assert first["status"] == "cancelled"
    done = run_study(client, worker, study_id)
    assert [t["status"] for t in done["trials"]] == ["cancelled", "succeeded"]

    assert client.post(f"/api/studies/{study_id}/rerun-failed", headers=JSON).json()["rerun"] == 1
    done = run_study(client, worker, study_id)
    trial = done["trials"][0]
    assert trial["status"] == "succeeded"
    assert trial["job_ids"][0] == single_job and len(trial["job_ids"]) == 2  # single stood; multi ran anew
    with db.session() as session:
        new_multi = session.get(Job, trial["job_ids"][1])
        assert (new_multi.system, new_multi.status) == ("multi", "succeeded")


def test_a_trial_whose_other_system_failed_cancels_its_queued_sibling(client: TestClient, worker: Worker,
                                                                      db: Database) -> None:
    study = grid(base={"system": ["single", "multi"], "seeds": 2, "episodes": 10},
                 space={"half_saturation": {"values": [0.15]}}, objective={"metric": "paper_deviation"})
    study_id = submit(client, study)
    single_job, multi_job = detail(client, study_id)["trials"][0]["job_ids"]
    client.post(f"/api/jobs/{single_job}/cancel", headers=JSON)
    with db.session() as session:
        assert session.get(Job, multi_job).status == "cancelled"
    assert detail(client, study_id)["study"]["status"] == "finished"
    assert not worker.run_once()


def test_a_study_whose_trials_run_until_decided_says_which_stopped_at_max_seeds(client: TestClient,
                                                                                  worker: Worker) -> None:
    """The base's until goes to every trial's job; a trial's objective stands on the seeds its rule ran; the
    trials whose rule reached max_seeds unanswered are named (issue "seeds until decided")."""
    from mgrao_core import run_experiment
    from mgrao_core.statistics.sequential import run_until, until_spec

    rules = {"loose": {"half_width": 50, "block": 10, "max_seeds": 30},
             "strict": {"half_width": 0.01, "max_seeds": 20}}
    for name, rule in rules.items():
        study_id = submit(client, {"name": name, "base": {"system": "single", "episodes": 20, "first_seed": 5,
                                                          "until": rule},
                                   "space": {"learning_rate": {"values": [0.05, 0.2]}},
                                   "objective": {"metric": "pct_from_uniform", "direction": "maximize",
                                                 "configuration": "mgrao-max"}})
        answer = run_study(client, worker, study_id)
        assert answer["definition"]["base"]["until"]["max_seeds"] == rule["max_seeds"]
        for trial in answer["trials"]:
            job = client.get(f"/api/jobs/{trial['job_ids'][0]}").json()
            spec, until = until_spec("single", None, 5, 20, {"learning_rate": trial["params"]["learning_rate"]},
                                     rule)
            expected = run_until(spec, until, run_experiment)
            assert job["stopped"]["reason"] == expected.stopped.reason
            assert job["seeds"] == list(expected.result.spec.seeds)
            assert trial["value"] == pytest.approx(expected.result.summary()["mgrao-max"].pct_from_uniform, abs=1e-12)
            assert trial["max_seeds_jobs"] == ([job["id"]] if job["stopped"]["reason"] == "max_seeds" else [])
        reasons = {client.get(f"/api/jobs/{t['job_ids'][0]}").json()["stopped"]["reason"] for t in answer["trials"]}
        assert reasons == ({"half_width"} if name == "loose" else {"max_seeds"})
    objective = {"metric": "pct_from_uniform", "direction": "maximize", "configuration": "mgrao-max"}
    refused = client.post("/api/studies", json={"base": {"seeds": 5, "until": {"half_width": 1}},
                                                "space": {"learning_rate": {"values": [0.1]}}, "objective": objective})
    assert refused.status_code == 422 and refused.json()["detail"][0]["field"] == "base.seeds"
    refused = client.post("/api/studies", json={"base": {"until": {"decide": ["mgrao-max", "oracle"]}},
                                                "space": {"learning_rate": {"values": [0.1]}}, "objective": objective})
    assert refused.status_code == 422 and refused.json()["detail"][0]["field"] == "base.until.decide"
