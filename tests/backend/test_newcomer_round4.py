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
