"""``POST /api/jobs/check`` (and ``POST /api/jobs``) name every refused field at once, in the product's words.

Issue 30, point 6: the check answered the first bad parameter only; seeds of 1e9 and episodes of 2.5 came
after the work limit; the validation library's wording reached users.
"""

from __future__ import annotations

from backend_helpers import JSON
from fastapi.testclient import TestClient

BAD_PARAMS = {"learning_rate": 5, "n_types": 100000, "resource_mean": -1}


def check(client: TestClient, body: dict) -> list[dict]:
    answer = client.post("/api/jobs/check", json=body, headers=JSON).json()
    assert answer["valid"] is False, answer
    return answer["detail"]


def test_every_refused_parameter_is_named_at_once(client: TestClient) -> None:
    body = {"system": "single", "params": BAD_PARAMS}
    detail = check(client, body)
    assert [d["field"] for d in detail] == ["learning_rate", "n_types", "resource_mean"]
    assert [d["msg"] for d in detail] == ["learning_rate: must be in [0, 1] (got 5)",
                                          "n_types: must be in [2, 200] (got 100000)",
                                          "resource_mean: must be in [0.001, 1] (got -1)"]
    submitted = client.post("/api/jobs", json=body)
    assert submitted.status_code == 422 and submitted.json()["detail"] == detail  # the very refusal a submit gets


def test_a_fields_own_rule_comes_before_the_work_limit_and_beside_the_parameters(client: TestClient) -> None:
    detail = check(client, {"system": "single", "seeds": 1e9, "episodes": 2.5, "params": BAD_PARAMS})
    assert {d["field"]: d["msg"] for d in detail} == {
        "seeds": "seeds: must be at most 1000 (got 1000000000)",
        "episodes": "episodes: must be a whole number (got 2.5)",
        "learning_rate": "learning_rate: must be in [0, 1] (got 5)",
        "n_types": "n_types: must be in [2, 200] (got 100000)",
        "resource_mean": "resource_mean: must be in [0.001, 1] (got -1)"}
    detail = check(client, {"system": "single", "seeds": 1000000000, "algorithms": ["mgrao-3:1"]})
    assert [d["msg"] for d in detail] == [
        "seeds: must be at most 1000 (got 1000000000)",
        "algorithms[0]: mgrao-3:1: x must be a divisor of n_parents = 10 (valid: 1, 2, 5, 10)"]


def test_the_schemas_refusals_are_said_in_the_products_words(client: TestClient) -> None:
    said = {d["field"]: d["msg"] for d in check(client, {"system": "single", "algorithms": [], "bogus": 1})}
    assert said == {"algorithms": "algorithms: must have at least 1 item (got 0)",
                    "bogus": "bogus: is not a field of this body"}
    saved = client.post("/api/systems/saved", json={"name": "Rush hour", "base": "single", "params": {}})
    assert saved.json()["detail"][0]["msg"] == ("name: must be 1-32 characters: a lowercase letter, then lowercase "
                                                "letters, digits or '-'")
    assert client.post("/api/systems/saved", json={"name": "rush", "base": "single", "params": {}}).status_code == 201
    again = client.post("/api/systems/saved", json={"name": "rush", "base": "single", "params": {}})
    assert again.status_code == 409 and "PUT" not in again.json()["detail"]
    assert again.json()["detail"] == "a saved system is already called 'rush': give this one another name, or replace "\
                                     "that one"
    listed = client.get("/api/jobs?limit=0").json()["detail"][0]["msg"]
    assert listed == "limit: must be at least 1 (got 0)"
