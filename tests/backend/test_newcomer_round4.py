"""A newcomer's first hour, round 4 (issue 43): what the service's answers say."""

from __future__ import annotations

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
