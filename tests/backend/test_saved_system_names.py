"""A saved system is named by its own name wherever a system is named (issue 47, item 3).

A job of a saved system stores its base preset as ``system`` (its world and config_hash are the
preset-with-overrides job's) and carries the tag ``system:<name>``. Compare's groups, the statistics and
their CSV, LaTeX and text renderings, and ``mgrao compare`` named ``large30`` (large with 30 parents) as
``large``, the paper's 50-parent system. The rule for a world whose jobs ran several names, or a saved
system and its preset, is docs/statistics.md's ("Names"). On SQLite and PostgreSQL.
"""

from __future__ import annotations

import csv
import io

from backend_helpers import JSON, Service, drain
from click.testing import CliRunner
from fastapi.testclient import TestClient

from backend.execution.worker import Worker
from mgrao_cli.main import cli

ALGORITHMS = ["uniform", "mgrao-max", "oracle"]
LARGE30 = {"name": "large30", "description": "large with 30 parents", "base": "large", "params": {"n_parents": 30}}


def _saved(post, body: dict) -> None:
    answer = post("/api/systems/saved", json=body)
    assert answer.status_code == 201, answer.text


def _job(post, system: str, episodes: int = 5, **params: object) -> int:
    answer = post("/api/jobs", json={"system": system, "algorithms": ALGORITHMS, "seeds": 3, "episodes": episodes,
                                     "params": params})
    assert answer.status_code == 202, answer.text
    return answer.json()["id"]


def test_a_saved_system_is_named_in_compare_the_statistics_their_exports_and_the_cli(service: Service) -> None:
    service.start_server(workers=1)
    _saved(service.post, LARGE30)
    mine, paper = _job(service.post, "large30"), _job(service.post, "large")
    ids = f"{mine},{paper}"
    service.wait_for(lambda: all(service.get(f"/api/jobs/{i}").json()["status"] == "succeeded" for i in (mine, paper)),
                     timeout=600, what="both jobs succeeded")
    job = service.get(f"/api/jobs/{mine}").json()
    assert (job["system"], job["saved_system"]) == ("large", "large30")

    groups = service.get("/api/compare", params={"jobs": ids}).json()["groups"]
    named = {(g["system"], g["base"], g["world"]) for g in groups}
    assert named == {("large30", "large", "large30"), ("large", "large", "large")}
    assert {g["algorithm"] for g in groups if g["world"] == "large30"} == set(ALGORITHMS)

    query = {"jobs": ids, "reps": 200}
    answer = service.get("/api/compare/statistics", params=query).json()
    assert set(answer["systems"]) == set(answer["normalisation"]) == {"large30", "large"}
    assert {(c["system"], c["base"]) for c in answer["configurations"]} == {("large30", "large"), ("large", "large")}
    assert set(answer["protocol"]["episodes"]) == {"large30", "large"}

    rows = list(csv.reader(line for line in io.StringIO(
        service.get("/api/compare/statistics", params=query | {"format": "csv"}).text) if not line.startswith("#")))
    assert sorted({r[0] for r in rows[1:]} - {"aggregate"}) == ["large", "large30"]
    assert sum(r[0] == "large30" for r in rows) == len(ALGORITHMS)
    latex = service.get("/api/compare/statistics", params=query | {"format": "latex"}).text
    assert "large30 &" in latex and "large &" in latex
    table = service.get("/api/compare/statistics", params=query | {"format": "table"}).text
    assert "large30" in table

    printed = CliRunner().invoke(cli, ["compare", ids, "--url", service.base, "--reps", "200"])
    assert printed.exit_code == 0, printed.output
    lines = printed.output.splitlines()
    assert sum(line.startswith("large30 ") for line in lines) == len(ALGORITHMS), printed.output
    assert sum(line.startswith("large ") for line in lines) == len(ALGORITHMS), printed.output


def _names(client: TestClient, *ids: int) -> set[tuple[str, str]]:
    groups = client.get("/api/compare", params={"jobs": ",".join(map(str, ids))}).json()["groups"]
    return {(g["system"], g["world"]) for g in groups}


def test_the_rule_for_a_world_of_several_names_or_of_a_saved_system_and_its_preset(client: TestClient,
                                                                                 worker: Worker) -> None:
    # a12 and b12: one definition saved under two names (single with 12 parents)
    for name in ("a12", "b12"):
        _saved(client.post, {"name": name, "base": "single", "params": {"n_parents": 12}})
    a5, plain5, b6, a6 = (_job(client.post, "a12"), _job(client.post, "single", n_parents=12),
                          _job(client.post, "b12", episodes=6), _job(client.post, "a12", episodes=6))
    assert drain(worker) == 4

    # a saved system and its preset with the same overrides are one world: the saved system's name, in any order
    assert _names(client, a5, plain5) == _names(client, plain5, a5) == {("a12", "a12")}
    assert _names(client, plain5) == {("single", "single")}  # the preset's own job alone keeps the preset's name
    # one definition under two names: both, alphabetically, for every world of the system (other episodes too)
    assert _names(client, b6, a6) == _names(client, a6, b6) == {("a12 = b12", "a12 = b12")}
    assert _names(client, a5, b6) == {("a12 = b12", "a12 = b12 (episodes=5)"), ("a12 = b12", "a12 = b12 (episodes=6)")}
    assert _names(client, a5, plain5, a6) == {("a12", "a12 (episodes=5)"), ("a12", "a12 (episodes=6)")}
    # the name stands on the jobs' tags, so an answer kept for these jobs is not one named before a tag changed
    assert client.patch(f"/api/jobs/{a5}", json={"tags": ["renamed"]}).status_code == 200
    assert _names(client, a5, plain5) == {("single", "single")}


def test_one_name_redefined_names_its_worlds_by_what_differs(client: TestClient, worker: Worker) -> None:
    _saved(client.post, {"name": "mine", "base": "single", "params": {"n_parents": 12}})
    old = _job(client.post, "mine")
    replaced = client.put("/api/systems/saved/mine", headers=JSON,
                          json={"name": "mine", "base": "single", "params": {"n_parents": 8}})
    assert replaced.status_code == 200, replaced.text
    new = _job(client.post, "mine")
    assert drain(worker) == 2
    assert _names(client, old, new) == {("mine", "mine (n_parents=12)"), ("mine", "mine (n_parents=8)")}
