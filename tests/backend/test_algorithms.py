"""``GET /api/algorithms``: the core's registry as the API serves it, and labels described one by one."""

from __future__ import annotations

from fastapi.testclient import TestClient

from mgrao_core import PRESETS
from mgrao_core.algorithms import FAMILIES, describe_label, registry, sort_key


def test_registry_is_the_cores_one_family_per_entry(client: TestClient) -> None:
    answer = client.get("/api/algorithms")
    assert answer.status_code == 200, answer.text
    data = answer.json()["data"]
    assert [f["name"] for f in data] == [f.name for f in FAMILIES]
    assert data == registry(None)
    for family in data:
        assert family["forms"] and family["examples"] and family["title"] and family["description"]


def test_registry_for_a_system_gives_its_valid_arguments(client: TestClient) -> None:
    data = client.get("/api/algorithms", params={"system": "large"}).json()["data"]
    assert data == registry(PRESETS["large"].params)
    with_argument = [form for f in data for form in f["forms"] if form["argument"]]
    assert with_argument and all(form["valid"] for form in with_argument)
    examples = [label for f in data for label in f["examples"]]
    assert set(PRESETS["large"].algorithms) <= set(examples)
    # a form's parent count beside the preset's
    twelve = client.get("/api/algorithms", params={"system": "single", "n_parents": 12}).json()["data"]
    valid = {f["name"]: form["valid"] for f in twelve for form in f["forms"] if form["argument"]}
    assert valid == {"mgrao": [1, 2, 3, 4, 6, 12], "mgrao-adaptive": list(range(1, 13)),  # adaptive: any x
                     "mgrao-balance": [1, 2, 3, 4, 6, 12]}


def test_unknown_system_or_parents_without_one_is_a_422_naming_the_field(client: TestClient) -> None:
    answer = client.get("/api/algorithms", params={"system": "huge"})
    assert answer.status_code == 422
    assert [d["field"] for d in answer.json()["detail"]] == ["system"]
    answer = client.get("/api/algorithms", params={"n_parents": 12})
    assert answer.status_code == 422 and answer.json()["detail"][0]["field"] == "n_parents"
    answer = client.get("/api/algorithms", params={"system": "single", "n_parents": 0})
    assert answer.status_code == 422 and answer.json()["detail"][0]["field"] == "n_parents"


def test_label_is_canonicalised_and_described(client: TestClient) -> None:
    answer = client.get("/api/algorithms", params={"label": " MGRAO-05:1"})
    assert answer.status_code == 200, answer.text
    [described] = answer.json()["data"]
    assert described == describe_label("mgrao-5:1") and described["label"] == "mgrao-5:1"
    assert described["sort_key"] == list(sort_key("mgrao-5:1")[:2])
    several = client.get("/api/algorithms", params=[("label", "mgrao-max"), ("label", "mgrao-1:1"),
                                                    ("label", "mgrao-5:1"), ("system", "large")]).json()["data"]
    assert [d["label"] for d in several] == ["mgrao-max", "mgrao-1:1", "mgrao-5:1"]
    assert len({d["colour_key"] for d in several}) == 3  # 1:1, 5:1 and max differ
    large = [client.get("/api/algorithms", params={"label": a}).json()["data"][0] for a in PRESETS["large"].algorithms]
    assert len({d["colour_key"] for d in large}) == len(large)  # large's 7 configurations each their own slot


def test_bad_label_is_a_422_naming_label_with_the_cores_message(client: TestClient) -> None:
    answer = client.get("/api/algorithms", params={"label": "mgrao-3:1", "system": "large"})
    assert answer.status_code == 422
    [detail] = answer.json()["detail"]
    assert detail["field"] == "label" and detail["loc"] == ["query", "label"]
    assert "x must be a divisor of n_parents = 50" in detail["msg"] and detail["msg"].startswith("label: ")
    answer = client.get("/api/algorithms", params=[("label", "uniform"), ("label", "greedy")])
    assert answer.status_code == 422
    assert answer.json()["detail"][0]["field"] == "label[1]" and "unknown algorithm 'greedy'" in answer.text


def test_systems_algorithms_come_from_the_registry(client: TestClient) -> None:
    algorithms = client.get("/api/systems").json()["algorithms"]
    # spelling and values of before, with the examples of families added since (issue 21's) in view order
    assert algorithms["fixed"] == ["uniform", "mgrao-1:1", "mgrao-max", "mgrao-adaptive:2", "mgrao-adaptive:5",
                                   "mgrao-balance", "independent-q", "bandit", "oracle"]
    assert algorithms["pattern"] == "mgrao-<x>:1, mgrao-<x>:<y>, mgrao-adaptive:<x>, mgrao-balance:<M>"
    assert (algorithms["baseline"], algorithms["reference"], algorithms["best_fixed"]) == (
        "uniform", "mgrao-max", "oracle")


def test_the_registry_answers_for_saved_systems_and_a_systems_overrides(client) -> None:
    """Issue 30, point 3: a saved system based on large with n_parents=30 got large's valid x (1, 2, 5, 10, ...)."""
    import json

    assert client.post("/api/systems/saved", json={"name": "walk-p30", "base": "large",
                                                  "params": {"n_parents": 30}}).status_code == 201
    assert client.post("/api/systems/saved", json={"name": "two-resources", "base": "single",
                                                  "params": {"n_resources": 2}}).status_code == 201

    def mgrao(query: str) -> dict:
        answer = client.get(f"/api/algorithms?{query}")
        assert answer.status_code == 200, answer.text
        return next(f for f in answer.json()["data"] if f["name"] == "mgrao")

    family = mgrao("system=walk-p30")
    form, shared = [f for f in family["forms"] if f["argument"]]
    assert form["valid"] == shared["valid"] == [1, 2, 3, 5, 6, 10, 15, 30]
    assert family == mgrao("system=large&params=" + json.dumps({"n_parents": 30}))
    two = mgrao("system=two-resources")["memory_per_child"]
    one = mgrao("system=single")["memory_per_child"]
    assert two["mgrao-max"] > one["mgrao-max"]  # one PW row per resource
    described = client.get("/api/algorithms?system=walk-p30&label=mgrao-15:1").json()["data"][0]
    assert described["groups"] == 15
    for query, field in (("system=nowhere", "system"), ("params=%7B%7D", "params"),
                         ("system=large&params=%5B%5D", "params"), ("system=large&params=" + json.dumps({"n_types": 1}),
                                                                    "params"),
                         ("system=walk-p30&label=mgrao-4:1", "label")):
        answer = client.get(f"/api/algorithms?{query}")
        assert answer.status_code == 422 and answer.json()["detail"][0]["field"] == field, (query, answer.text)


def test_the_registry_gives_the_valid_y_of_shared_models_for_a_system(client) -> None:
    """Issue 45: mgrao-x:y, y children sharing one model; y must divide n_children."""
    import json

    assert client.post("/api/systems/saved", json={"name": "six-children", "base": "multi",
                                                  "params": {"n_children": 6}}).status_code == 201
    for query in ("system=six-children", "system=multi&params=" + json.dumps({"n_children": 6})):
        family = next(f for f in client.get(f"/api/algorithms?{query}").json()["data"] if f["name"] == "mgrao")
        shared = next(form for form in family["forms"] if form.get("second_argument") == "y")
        assert shared["template"] == "mgrao-{x}:{y}" and shared["second_valid"] == [2, 3, 6]
        assert shared["valid"] == [1, 2, 5, 10]
    described = client.get("/api/algorithms", params=[("system", "six-children"), ("label", "mgrao-05:03"),
                                                      ("label", "mgrao-5:1")]).json()["data"]
    assert [(d["label"], d["team_size"]) for d in described] == [("mgrao-5:3", 3), ("mgrao-5:1", 1)]
    assert described[0]["memory_per_child"] == -(-described[1]["memory_per_child"] // 3)
    answer = client.get("/api/algorithms", params={"system": "multi", "label": "mgrao-5:2"})
    assert answer.status_code == 422
    [detail] = answer.json()["detail"]
    assert detail["field"] == "label"
    assert "y must be a divisor of n_children = 3 (valid: 1, 3)" in detail["msg"]
    answer = client.post("/api/jobs", json={"system": "multi", "algorithms": ["uniform", "mgrao-5:2"], "seeds": 1,
                                            "episodes": 2})
    assert answer.status_code == 422
    assert any(d["field"] == "algorithms[1]" and "(valid: 1, 3)" in d["msg"] for d in answer.json()["detail"])
