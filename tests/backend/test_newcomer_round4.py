"""A newcomer's first hour, round 4 (issue 43): what the service's answers say."""

from __future__ import annotations

import pytest
from backend_helpers import drain
from fastapi.testclient import TestClient

from backend.execution.worker import Worker


def submit(client: TestClient, **body: object) -> dict:
    answer = client.post("/api/jobs", json={"system": "single", "episodes": 12, **body})
    assert answer.status_code == 202, answer.text
    return answer.json()


def test_compare_lists_a_job_whose_seeds_are_a_subset_of_anothers_as_read_and_checked(
        client: TestClient, worker: Worker) -> None:
    """Issue 43, item 15: the subset job was read and checked, but not in the group's ``job_ids``."""
    whole = submit(client, seeds=4, algorithms=["uniform", "mgrao-1:1"])
    part = submit(client, seeds=[1, 2], algorithms=["uniform", "mgrao-1:1"])
    assert drain(worker) == 2
    answer = client.get(f"/api/compare?jobs={whole['id']},{part['id']}")
    assert answer.status_code == 200, answer.text
    for group in answer.json()["groups"]:
        assert group["job_ids"] == [whole["id"], part["id"]], group
        assert group["checked_job_ids"] == [part["id"]] and group["summary"]["n_runs"] == 4, group
    statistics = client.get(f"/api/compare/statistics?jobs={whole['id']},{part['id']}&reps=10")
    assert statistics.status_code == 200, statistics.text
    for configuration in statistics.json()["configurations"]:
        assert configuration["job_ids"] == [whole["id"], part["id"]], configuration
        assert configuration["checked_job_ids"] == [part["id"]], configuration
    # asked the other way round, the part gives seeds 1-2 first and the whole job the rest: both stand
    answer = client.get(f"/api/compare?jobs={part['id']},{whole['id']}")
    for group in answer.json()["groups"]:
        assert group["job_ids"] == [part["id"], whole["id"]] and group["checked_job_ids"] == [], group


def test_sorting_by_name_puts_unnamed_jobs_last_in_either_direction_page_by_page(client: TestClient) -> None:
    """Issue 43, item 14: "Name A-Z" put the unnamed "job 1" first (an empty name sorts before every other)."""
    names = ["beta", "", "Alpha", "", "gamma", "", "delta"]
    ids = [submit(client, seeds=1, algorithms=["uniform"], name=name)["id"] for name in names]
    unnamed = [i for i, name in zip(ids, names, strict=True) if not name]
    for sort, named in (("name", ["Alpha", "beta", "delta", "gamma"]), ("-name", ["gamma", "delta", "beta", "Alpha"])):
        for limit in (2, 3, 100):  # pages that end among the named, at the change, among the unnamed
            seen, cursor = [], None
            while True:
                answer = client.get("/api/jobs", params={"sort": sort, "limit": limit} | ({"cursor": cursor}
                                                                                         if cursor else {}))
                assert answer.status_code == 200, answer.text
                seen += answer.json()["data"]
                cursor = answer.json()["next_cursor"]
                if cursor is None:
                    break
            assert [j["name"] for j in seen[:4]] == named, (sort, limit, seen)
            assert [j["id"] for j in seen[4:]] == (unnamed if sort == "name" else unnamed[::-1]), (sort, limit)


def test_a_jobs_results_say_what_learning_cost_and_which_groups_balance_settled_on_and_the_oracles_caveat(
        client: TestClient, worker: Worker) -> None:
    """Issue 43, items 7 and 8: the oracle's caveat was compare's alone; the cost learning took and mgrao-balance's
    group count at the end were nowhere (it "stores no group weights")."""
    from collections import Counter

    from mgrao_core import make_spec, run_experiment
    from mgrao_core.algorithms import groups_at_end, parse_algorithm, task_share
    from mgrao_core.algorithms.oracle import bound_caveats

    body = {"system": "multi", "algorithms": ["uniform", "mgrao-1:1", "mgrao-balance", "oracle"], "seeds": 2,
            "episodes": 40, "params": {"learning_cost": 0.3}}
    job = submit(client, **body)
    assert drain(worker) == 1
    answer = client.get(f"/api/jobs/{job['id']}/results?points=10")
    assert answer.status_code == 200, answer.text
    results = answer.json()
    spec = make_spec("multi", body["algorithms"], seeds=2, episodes=40, overrides=body["params"])
    assert results["oracle_caveats"] == bound_caveats(spec.params) and results["oracle_caveats"]
    learning = {c["algorithm"]: c["learning"] for c in results["configurations"]}
    assert learning["uniform"] is None and learning["oracle"] is None  # they learn nothing
    one = parse_algorithm("mgrao-1:1", spec.params.n_parents)
    share = 1 - task_share(one, spec.params)
    assert learning["mgrao-1:1"] == {"groups": {"1": 2 * spec.params.n_children}, "children": 6,
                                     "groups_change": False, "taken": {"mean": share, "low": share, "high": share}}
    assert learning["mgrao-balance"]["groups_change"] is True
    # mgrao-balance: each child's groups at the end of the core's own runs, and the share that many groups take
    runs = [r for r in run_experiment(spec).runs if r.algorithm == "mgrao-balance"]
    ended = Counter(g for r in runs for g in groups_at_end(r.membership).tolist())
    balance = parse_algorithm("mgrao-balance", spec.params.n_parents)
    assert learning["mgrao-balance"]["groups"] == {str(g): n for g, n in sorted(ended.items())}
    taken = {g: 1 - task_share(balance, spec.params, g) for g in ended}
    assert learning["mgrao-balance"]["taken"]["mean"] == pytest.approx(
        sum(taken[g] * n for g, n in ended.items()) / sum(ended.values()))
    assert learning["mgrao-balance"]["taken"]["high"] == max(taken.values())
    assert max(ended) > 1  # it split at least once: more groups than it started with
    # without the oracle, no caveat; without a cost, the groups alone
    job = submit(client, seeds=1, algorithms=["uniform", "mgrao-1:1"])
    assert drain(worker) == 1
    results = client.get(f"/api/jobs/{job['id']}/results?points=10").json()
    assert results["oracle_caveats"] is None
    assert {c["algorithm"]: c["learning"] for c in results["configurations"]}["mgrao-1:1"]["taken"] is None


def test_a_job_says_while_its_worker_compiles_for_it_and_counts_the_seconds_apart(
        client: TestClient, settings) -> None:  # noqa: ANN001
    """Issue 43, items 2 and 11: nothing said a job was compiling; its duration hid the compile and the wait."""
    from backend.execution.heartbeats import Heartbeats
    from backend.store import queue
    from backend.store.db import Database
    from mgrao_core.compiling import Compiling
    from tests.support.waiting import wait_until

    job = submit(client, seeds=1, algorithms=["uniform", "bandit"])
    db = Database(settings.database_url)
    beats = Heartbeats(db, heartbeat_s=0.2, progress_s=0.1)
    try:
        claim = queue.claim(db, worker_id="test", stale_after_s=60, max_attempts=3)
        assert claim is not None and claim.job_id == job["id"]
        beats.add(claim)
        beats.start()
        notice = Compiling(("engine", "bandit"), 20.0)
        beats.compiling(job["id"], notice)
        shown = wait_until(lambda: client.get(f"/api/jobs/{job['id']}").json()["compiling"], 10,
                           "the job to say that its worker compiles")
        assert shown["message"] == notice.message and shown["parts"] == ["engine", "bandit"] and shown["since"]
        assert client.get("/api/jobs?limit=5").json()["data"][0]["compiling"]["message"] == notice.message
        beats.compiling(job["id"], Compiling(("engine", "bandit"), 20.0, seconds=12.5))
        done = wait_until(lambda: (j := client.get(f"/api/jobs/{job['id']}").json())["compile_s"] and j, 10,
                          "the job to count its compile")
        assert done["compiling"] is None and done["compile_s"] == 12.5
        beats.compiling(job["id"], Compiling(("engine", "bandit"), 20.0, seconds=0.5))  # a second chunk's compile
        wait_until(lambda: client.get(f"/api/jobs/{job['id']}").json()["compile_s"] == 13.0, 10,
                   "the job to add a second compile's seconds")
        assert done["queued_s"] is not None and done["queued_s"] >= 0
    finally:
        beats.close()
        db.dispose()
