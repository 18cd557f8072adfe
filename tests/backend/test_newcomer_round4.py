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
