"""Jobs run until their question is answered (``until``): each rule, bad input, cancel, resume after SIGKILL.

Every test runs on a SQLite file and on a real PostgreSQL server (the ``db_url`` fixture). The numbers of a job
are checked against :func:`mgrao_core.statistics.sequential.run_until` in this process: the same seeds, the same
verdicts.
"""

from __future__ import annotations

import os
import signal
import threading

import pytest
from backend_helpers import JSON, Service, drain
from sqlalchemy import func, select

from backend.store.models import Run
from mgrao_core import run_experiment
from mgrao_core.statistics.sequential import run_until, stopped_dict, until_spec
from tests.support.waiting import wait_until

LABELS = ["uniform", "mgrao-1:1", "mgrao-max"]


def _in_process(rule: dict, first_seed: int, episodes: int, algorithms=None):
    spec, until = until_spec("single", algorithms or LABELS, first_seed, episodes, {}, rule)
    return run_until(spec, until, run_experiment)


def _stored_runs(db_url: str, job_id: int) -> int:
    from backend.store.db import Database

    db = Database(db_url)
    try:
        with db.session() as session:
            return session.scalar(select(func.count()).select_from(Run).where(Run.job_id == job_id))
    finally:
        db.dispose()


@pytest.mark.parametrize("rule", [
    {"half_width": 3, "block": 5, "max_seeds": 60},
    {"decide": ["mgrao-max", "mgrao-1:1"], "half_width": 1, "block": 4, "max_seeds": 40},
    {"half_width": 0.001, "of": "final_utility", "block": 7, "max_seeds": 20},
])
def test_a_job_runs_blocks_until_its_rule_answers_as_in_process(client, single_worker, db_url, rule):
    submitted = client.post("/api/jobs", json={"system": "single", "episodes": 30, "first_seed": 500, "until": rule})
    assert submitted.status_code == 202, submitted.text
    job = submitted.json()
    assert job["until"]["block"] == rule["block"] and job["stopped"] == {
        "reason": None, "seeds": 0, "outcome": None, "intervals": {}, "blocks": [], "level": 0.95,
        "coverage": "pair" if "decide" in rule else "each"}
    drain(single_worker)
    done = client.get(f"/api/jobs/{job['id']}").json()
    expected = _in_process(rule, 500, 30)
    assert done["status"] == "succeeded"
    assert done["stopped"] == stopped_dict(expected.blocks, done["until"])  # the same verdict after every block
    assert done["stopped"]["reason"] in ("half_width", "decided", "max_seeds")
    n = expected.stopped.seeds
    assert done["seeds"] == list(range(500, 500 + n)) and _stored_runs(db_url, job["id"]) == 3 * n
    if "decide" not in rule and rule.get("of") != "final_utility":
        for label, (_, low, high) in done["stopped"]["intervals"].items():  # the summary's is the judged interval
            assert done["summaries"][label]["pct_ci95"] == pytest.approx([low, high], abs=1e-12)
    if rule.get("of") == "final_utility":
        assert done["stopped"]["reason"] == "max_seeds" and n == 20


@pytest.mark.parametrize("body, field, words", [
    ({"seeds": 20, "until": {"half_width": 1}}, "seeds", "give either seeds or until"),
    ({"first_seed": 4}, "first_seed", "goes with until"),
    ({"until": {"half_width": 0}}, "until.half_width", "more than 0"),
    ({"until": {"half_width": 1, "max_seeds": 5}}, "until.max_seeds", "at least 10"),
    ({"until": {"half_width": 1, "block": 60, "max_seeds": 50}}, "until.block", "at most max_seeds, 50"),
    ({"until": {"decide": ["mgrao-max", "oracle"]}}, "until.decide", "oracle: not run by this experiment"),
    ({"until": {"decide": ["mgrao-max", "mgrao-max"]}}, "until.decide", "two different"),
    ({"until": {"of": "final_utility"}}, "until.half_width", "is needed unless the rule decides a pair"),
    ({"until": {"half_width": 1}, "algorithms": ["mgrao-max"]}, "until.of", "pct_from_uniform needs uniform"),
    ({"until": {"half_width": 1, "bogus": 2}}, "until.bogus", ""),
    ({"until": {"half_width": 1}, "first_seed": 2**32 - 5}, "until.max_seeds", "the last seed"),
    ({"until": {"half_width": 1, "judge": ["oracle"]}}, "until.judge", "oracle: not run by this experiment"),
    ({"until": {"half_width": 1, "judge": ["uniform"]}}, "until.judge", "baseline of % from uniform"),
    ({"until": {"decide": ["mgrao-max", "mgrao-1:1"], "joint": True}}, "until.joint", "goes with the half_width"),
    ({"until": {"half_width": 1, "joint": "yes"}}, "until.joint", ""),
])
def test_a_bad_rule_is_refused_naming_the_field_and_stores_nothing(client, body, field, words):
    answer = client.post("/api/jobs", json={"system": "single", "episodes": 10} | body)
    assert answer.status_code == 422, answer.text
    detail = answer.json()["detail"]
    assert any(d["field"] == field and words in d["msg"] for d in detail), detail
    checked = client.post("/api/jobs/check", json={"system": "single", "episodes": 10} | body).json()
    assert checked["valid"] is False and any(d["field"] == field for d in checked["detail"]), checked
    assert client.get("/api/jobs").json()["data"] == []


def test_a_job_without_a_rule_says_nothing_of_one_and_pairs_with_one(client, single_worker):
    plain = client.post("/api/jobs", json={"system": "single", "episodes": 10, "seeds": 12}).json()
    ruled = client.post("/api/jobs", json={"system": "single", "episodes": 10,
                                           "until": {"half_width": 50, "max_seeds": 12, "block": 12}}).json()
    assert plain["until"] is None and plain["stopped"] is None
    assert ruled["config_hash"] == plain["config_hash"]  # the rule is not part of the world: they pair
    drain(single_worker)
    assert client.get(f"/api/jobs/{ruled['id']}").json()["stopped"]["reason"] == "half_width"


def test_a_cancel_stops_between_blocks_and_keeps_the_blocks_stored(client, single_worker, db_url):
    job = client.post("/api/jobs", json={"system": "single", "episodes": 400,
                                         "until": {"half_width": 0.001, "block": 2, "max_seeds": 1000}}).json()
    runner = threading.Thread(target=single_worker.run_once, daemon=True)
    runner.start()
    wait_until(lambda: (client.get(f"/api/jobs/{job['id']}").json()["stopped"] or {}).get("seeds", 0) >= 4, 120,
               "two blocks judged")
    assert client.post(f"/api/jobs/{job['id']}/cancel", headers=JSON).status_code == 200
    runner.join(timeout=120)
    assert not runner.is_alive(), "the worker did not stop after the cancel"
    done = client.get(f"/api/jobs/{job['id']}").json()
    assert done["status"] == "cancelled" and done["stopped"]["reason"] == "cancelled"
    judged = done["stopped"]["seeds"]
    assert judged >= 4 and len(done["stopped"]["blocks"]) == judged // 2
    stored = _stored_runs(db_url, job["id"])
    assert 3 * judged <= stored <= 3 * (judged + 2)  # the blocks judged, and at most the block under way


def test_a_worker_killed_between_blocks_resumes_to_the_same_decision(tmp_path, db_url):
    service = Service(tmp_path, db_url)
    try:
        service.start_server(workers=0)
        first = service.start_worker()
        rule = {"half_width": 0.05, "block": 2, "max_seeds": 40}  # undecided to 40 seeds: blocks left at the kill
        job = service.post("/api/jobs", json={"system": "single", "episodes": 6000, "first_seed": 40,
                                              "until": rule}).json()
        service.wait_mid_job(job["id"], lambda state: (state["stopped"] or {}).get("seeds", 0) >= 4,
                             "two blocks judged")
        os.kill(first.pid, signal.SIGKILL)
        first.wait(timeout=30)
        service.start_worker()
        done = service.wait_for(lambda: (lambda j: j if j["status"] == "succeeded" else None)(
            service.get(f"/api/jobs/{job['id']}").json()), timeout=240, what="the job resumed and succeeded")
        expected = _in_process(rule, 40, 6000)
        assert done["attempts"] >= 2
        assert done["stopped"] == stopped_dict(expected.blocks, done["until"])
        n = expected.stopped.seeds
        assert done["seeds"] == list(range(40, 40 + n)) and _stored_runs(db_url, job["id"]) == 3 * n
    finally:
        service.stop()


def test_the_rule_judges_the_learners_not_the_oracle_by_default(client, single_worker):
    # issue 47 item 4: the oracle's wide interval held cloud's rule to its max_seeds; now it is not judged unless
    # asked, and a joint rule widens each judged interval to 1 - 0.05/k
    body = {"system": "single", "episodes": 20, "algorithms": ["uniform", "mgrao-1:1", "mgrao-max", "oracle"]}
    plain = client.post("/api/jobs", json=body | {"until": {"half_width": 1000, "max_seeds": 20}}).json()
    asked = client.post("/api/jobs", json=body | {"until": {"half_width": 1000, "max_seeds": 20, "joint": True,
                                                            "judge": ["MGRAO-MAX", "oracle"]}}).json()
    decide = client.post("/api/jobs", json=body | {"until": {"decide": ["mgrao-01:1", "mgrao-max"],
                                                             "max_seeds": 20}}).json()
    assert plain["until"]["judge"] == ["mgrao-1:1", "mgrao-max"] and plain["until"]["joint"] is False
    assert asked["until"]["judge"] == ["mgrao-max", "oracle"] and asked["until"]["joint"] is True
    assert decide["until"]["decide"] == ["mgrao-1:1", "mgrao-max"] and decide["until"]["judge"] == []
    drain(single_worker)
    plain, asked = (client.get(f"/api/jobs/{job['id']}").json() for job in (plain, asked))
    assert set(plain["stopped"]["intervals"]) == {"mgrao-1:1", "mgrao-max"}
    assert set(asked["stopped"]["intervals"]) == {"mgrao-max", "oracle"}
    _, low, high = asked["stopped"]["intervals"]["mgrao-max"]
    _, low95, high95 = plain["stopped"]["intervals"]["mgrao-max"]
    assert high - low > high95 - low95  # the same seeds, each interval at 97.5%
    assert (asked["stopped"]["coverage"], asked["stopped"]["level"]) == ("joint", 0.975)
    assert (plain["stopped"]["coverage"], plain["stopped"]["level"]) == ("each", 0.95)
