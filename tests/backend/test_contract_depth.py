"""What the OpenAPI document promises beyond single operations: its links lead somewhere, a query parameter
the operation does not take is refused, an integer is what JSON Schema calls one, parameter groups have titles.
"""

from __future__ import annotations

import itertools
import re

import pytest
from backend_helpers import JSON, TOKEN
from fastapi.testclient import TestClient

from backend.api.routes.compare import JOBS_PATTERN, parse_ids
from backend.errors import BadQuery
from backend.store.job_order import SORT_PATTERN, parse_sort
from mgrao_core.params import GROUP_TITLES, PARAMETERS
from mgrao_core.search import MAX_TRIALS
from mgrao_core.spec import MAX_EPISODES, MAX_SEED_VALUE, MAX_SEEDS

SMALL = {"system": "single", "seeds": 2, "episodes": 5}


def test_every_link_leads_to_an_operation_and_fills_one_of_its_parameters(client: TestClient) -> None:
    document = client.get("/openapi.json").json()
    operations = {op["operationId"]: (path, method, op) for path, item in document["paths"].items()
                  for method, op in item.items()}
    count = 0
    for path, item in document["paths"].items():
        for method, op in item.items():
            for code, answer in op["responses"].items():
                for name, link in answer.get("links", {}).items():
                    count += 1
                    where = f"{method.upper()} {path} [{code}] {name}"
                    assert link["operationId"] in operations, where
                    _, _, target = operations[link["operationId"]]
                    taken = {f"{p['in']}.{p['name']}" for p in target.get("parameters", [])}
                    for parameter, expression in link.get("parameters", {}).items():
                        assert parameter in taken, f"{where}: {parameter} is not a parameter of the target"
                        assert expression.startswith(("$response.body#/", "$request.path.")), where
                    if "requestBody" in link:
                        assert "requestBody" in target, f"{where}: the target takes no body"
    assert count >= 40, count  # every resource, every operation on one (docs/api.md, "Links")


def test_a_job_created_links_to_its_results_with_the_id_it_answered(client: TestClient) -> None:
    document = client.get("/openapi.json").json()
    links = document["paths"]["/api/jobs"]["post"]["responses"]["202"]["links"]
    assert links["results"] == {"operationId": "job_results_api_jobs__job_id__results_get",
                                "parameters": {"path.job_id": "$response.body#/id"}}
    saved = document["paths"]["/api/systems/saved"]["post"]["responses"]["201"]["links"]
    assert saved["replace"]["requestBody"] == {  # the whole system again: following it replaces nothing by default
        "name": "$response.body#/name", "base": "$response.body#/base", "params": "$response.body#/params",
        "description": "$response.body#/description"}
    assert saved["run"] == {"operationId": "submit_job_api_jobs_post",
                            "requestBody": {"system": "$response.body#/name"}}


@pytest.mark.parametrize(("path", "known"), [
    ("/api/jobs?stauts=running", "config_hash, cursor, kind, limit, q, sort, status, system, tag"),
    ("/api/health?verbose=1", "no query parameters"),
    ("/api/compare?jobs=1&job=2", "jobs, points"),
])
def test_a_query_parameter_the_operation_does_not_take_is_refused_by_name(client: TestClient, path: str,
                                                                           known: str) -> None:
    answer = client.get(path)
    assert answer.status_code == 422, answer.text
    (detail,) = answer.json()["detail"]
    name = path.split("&")[-1].split("?")[-1].split("=")[0]
    assert detail == {"loc": ["query", name], "field": name, "type": "value_error",
                      "msg": f"{name}: is not a parameter of this operation (it takes {known})"}


def test_several_unknown_query_parameters_are_refused_at_once_and_known_ones_answer(client: TestClient) -> None:
    answer = client.get("/api/studies?a=1&b=2&a=3")
    assert [d["field"] for d in answer.json()["detail"]] == ["a", "b"]
    assert client.get("/api/jobs?status=running&limit=5").status_code == 200
    job = client.post("/api/jobs", json=SMALL).json()
    assert client.get(f"/api/jobs/{job['id']}/results?points=5&include_seeds=true").status_code == 409  # not run
    nameless = client.get("/api/health?=1").json()["detail"]
    assert [(d["field"], d["msg"][:40]) for d in nameless] == [("", "(a parameter without a name): is not a p")]


def test_an_unknown_query_parameter_is_named_beside_every_other_refused_field_and_nothing_happens(
        client: TestClient) -> None:
    answer = client.get("/api/jobs?limit=0&bogus=1")
    assert [d["field"] for d in answer.json()["detail"]] == ["bogus", "limit"], answer.text
    answer = client.post("/api/jobs?zz=1", json=SMALL | {"episodes": 2.5, "params": {"learning_rate": 7}})
    assert answer.status_code == 422
    assert [d["field"] for d in answer.json()["detail"]] == ["zz", "episodes"], answer.text
    valid = client.post("/api/jobs?zz=1", json=SMALL)  # valid but for zz: refused, and no job queued
    assert [d["field"] for d in valid.json()["detail"]] == ["zz"]
    assert client.get("/api/jobs").json()["count"] == 0


def test_a_write_without_its_token_answers_401_before_an_unknown_query_parameter(auth_client: TestClient) -> None:
    assert auth_client.post("/api/jobs?x=1", json=SMALL).status_code == 401
    answer = auth_client.post("/api/jobs?x=1", json=SMALL, headers={"Authorization": f"Bearer {TOKEN}"})
    assert [d["field"] for d in answer.json()["detail"]] == ["x"]


@pytest.mark.parametrize(("episodes", "accepted"), [(5.0, True), (5, True), (5.5, False), ("5", False), (True, False)])
def test_an_integer_may_be_written_with_a_zero_fraction_as_json_schema_allows(client: TestClient, episodes: object,
                                                                                accepted: bool) -> None:
    answer = client.post("/api/jobs", json=SMALL | {"episodes": episodes, "seeds": [0, 1.0]})
    assert (answer.status_code == 202) == accepted, answer.text
    if accepted:
        assert (answer.json()["episodes"], answer.json()["seeds"]) == (5, [0, 1])
    else:
        assert answer.json()["detail"][0]["field"] == "episodes"


def test_every_bound_of_a_number_is_one_json_schema_knows(client: TestClient) -> None:
    """Pydantic writes a bound it cannot fold into its own validator as ``ge``/``le``, which no reader of the
    document knows: the limits of episodes, seeds, trials were invisible to clients and to Schemathesis."""
    document = client.get("/openapi.json").json()
    foreign: list[str] = []

    def walk(node: object, where: str) -> None:
        if isinstance(node, dict):
            if node.get("type") in ("integer", "number"):
                foreign.extend(f"{where}: {key}" for key in ("ge", "le", "gt", "lt") if key in node)
            for key, value in node.items():
                walk(value, f"{where}/{key}")
        elif isinstance(node, list):
            for i, value in enumerate(node):
                walk(value, f"{where}/{i}")

    walk(document, "#")
    assert not foreign, foreign
    schemas = document["components"]["schemas"]
    episodes = schemas["JobCreate"]["properties"]["episodes"]
    assert (episodes["minimum"], episodes["maximum"]) == (1, MAX_EPISODES)
    count, listed = schemas["JobCreate"]["properties"]["seeds"]["anyOf"]
    assert (count["minimum"], count["maximum"]) == (1, MAX_SEEDS)
    assert (listed["items"]["minimum"], listed["items"]["maximum"]) == (0, MAX_SEED_VALUE)
    assert schemas["StudyCreate"]["properties"]["max_trials"]["maximum"] == MAX_TRIALS


def test_the_jobs_pattern_is_what_the_service_reads_as_job_ids() -> None:
    """Every text of up to five characters of " ,1\tx": the pattern matches it exactly when parse_ids reads it (the
    document's pattern is the contract Schemathesis holds the service to, in both directions)."""
    for n in range(6):
        for letters in itertools.product(" ,1\tx", repeat=n):
            text = "".join(letters)
            try:
                parse_ids(text)
                read = True
            except BadQuery:
                read = False
            assert bool(re.search(JOBS_PATTERN, text)) == read, repr(text)


@pytest.mark.parametrize(("sort", "read"), [
    ("created_at", True), ("-name", True), ("status", True), ("param.learning_rate", True),
    ("-pct_from_uniform:mgrao-max", True), ("final_mean:MGRAO-05:1", True),
    ("param.nothing", None), ("pct_of_max:nothing", None),  # the pattern's form; no such parameter, configuration
    ("", False), ("-", False), ("param.", False), ("final_mean:", False), ("--name", False), ("name ", False),
    ("created", False), ("final_mean", False), ("mgrao-max", False)])
def test_the_sort_pattern_is_the_forms_the_service_reads(sort: str, read: bool | None) -> None:
    try:
        parse_sort(sort)
        parsed = True
    except BadQuery:
        parsed = False
    assert bool(re.search(SORT_PATTERN, sort)) == (read is not False)
    assert parsed == bool(read)


def test_every_parameter_group_has_a_title_from_the_core(client: TestClient) -> None:
    systems = client.get("/api/systems").json()
    assert systems["group_titles"] == GROUP_TITLES
    assert {p.group for p in PARAMETERS} <= set(GROUP_TITLES)
    assert GROUP_TITLES["independent-q"] == "Independent Q (algorithm)"


def test_a_batch_names_the_field_of_the_job_it_refuses(client: TestClient) -> None:
    answer = client.post("/api/jobs/batch", headers=JSON, json={"jobs": [SMALL, SMALL | {"seeds": [1, "x"]}]})
    assert answer.status_code == 422
    assert [d["field"] for d in answer.json()["detail"]] == ["jobs[1].seeds[1]"], answer.text
