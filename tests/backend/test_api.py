"""The REST API against a real SQLite file, jobs run by a real worker driven in-process."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest
from backend_helpers import JSON, TOKEN, drain
from fastapi.testclient import TestClient
from sqlalchemy import func, select

from backend.api.app import frontend_dir
from backend.execution.worker import Worker
from backend.store import queue
from backend.store.db import Database
from backend.store.models import Run
from mgrao_core import MAX_EPISODES, PRESETS, make_spec, run_experiment
from mgrao_core.algorithms import describe_label

SMALL = {"system": "single", "seeds": 3, "episodes": 15}


def submit(client: TestClient, **body: object) -> dict:
    response = client.post("/api/jobs", json={**SMALL, **body})
    assert response.status_code == 202, response.text
    return response.json()


def test_submit_run_results_and_export_match_the_core(client: TestClient, worker: Worker) -> None:
    response = client.post("/api/jobs", json={**SMALL, "seeds": [4, 9, 2], "name": "base", "tags": ["paper"]})
    assert response.status_code == 202
    job = response.json()
    assert response.headers["location"] == f"/api/jobs/{job['id']}"
    assert job["status"] == "queued" and job["attempts"] == 0 and job["seeds"] == [4, 9, 2]
    assert set(job["params"]) == set(PRESETS["single"].params.as_dict())
    assert client.get(f"/api/jobs/{job['id']}/results").status_code == 409

    assert drain(worker) == 1
    done = client.get(f"/api/jobs/{job['id']}").json()
    assert done["status"] == "succeeded" and done["progress"] == 1.0 and done["attempts"] == 1
    assert done["duration_s"] is not None and done["finished_at"].endswith("Z")

    expected = run_experiment(make_spec("single", seeds=[4, 9, 2], episodes=15))
    rows = list(csv.DictReader(io.StringIO(client.get(f"/api/jobs/{job['id']}/episodes").text)))
    assert len(rows) == 3 * 3 * 15
    stored = {(r["algorithm"], int(r["seed"]), int(r["episode"])): float(r["utility"]) for r in rows}
    for run in expected.runs:
        got = np.array([stored[(run.algorithm, run.seed, e)] for e in range(15)])
        assert np.array_equal(got, run.utilities)  # bit-identical

    as_json = client.get(f"/api/jobs/{job['id']}/episodes?format=json").json()
    assert len(as_json) == len(rows) and as_json[0].keys() == {"job_id", "algorithm", "seed", "episode", "utility"}

    results = client.get(f"/api/jobs/{job['id']}/results").json()
    assert results["paper"] is None  # 15 episodes: the paper's tables are after 100
    assert results["algorithms"] == [describe_label(a) for a in job["algorithms"]]  # the view asks no more
    summary = expected.summary()
    tasks = expected.task_counts()  # no task can fail here: both rates 0.0
    bands = expected.episode_bands()
    for config in results["configurations"]:
        algorithm = config["algorithm"]
        assert config["config_hash"] == job["config_hash"]
        assert config["summary"] == summary[algorithm].as_dict() | tasks[algorithm].rates()
        assert config["episodes"] == bands[algorithm]
        assert "seeds" not in config
        combined = np.mean([r.combined_weights for r in expected.runs if r.algorithm == algorithm], axis=0)
        assert np.allclose(config["weights"]["combined"], combined)
        assert (config["weights"]["groups"] == []) == (algorithm == "uniform")


def test_results_downsampling_and_seeds(client: TestClient, worker: Worker) -> None:
    job = submit(client, episodes=40)
    drain(worker)
    results = client.get(f"/api/jobs/{job['id']}/results?points=8&include_seeds=true").json()
    config = results["configurations"][0]
    assert len(config["episodes"]["episode"]) == 8
    assert [s["seed"] for s in config["seeds"]] == [0, 1, 2]
    assert all(len(s["utility"]) == 8 for s in config["seeds"])


def test_paper_is_null_when_params_differ(client: TestClient, worker: Worker) -> None:
    job = submit(client, params={"learning_rate": 0.2})
    drain(worker)
    assert client.get(f"/api/jobs/{job['id']}/results").json()["paper"] is None


def test_cancel_and_delete_state_rules(client: TestClient, db: Database) -> None:
    queued = submit(client)
    cancelled = client.post(f"/api/jobs/{queued['id']}/cancel", headers=JSON)
    assert cancelled.status_code == 200 and cancelled.json()["status"] == "cancelled"
    assert client.post(f"/api/jobs/{queued['id']}/cancel", headers=JSON).status_code == 409

    running = submit(client)
    claim = queue.claim(db, worker_id="w", stale_after_s=60, max_attempts=3)
    assert claim is not None and claim.job_id == running["id"]
    assert client.delete(f"/api/jobs/{running['id']}", headers=JSON).status_code == 409
    assert client.get(f"/api/jobs/{running['id']}/results").status_code == 409
    assert client.post(f"/api/jobs/{running['id']}/cancel", headers=JSON).json()["status"] == "cancelled"
    assert queue.heartbeat(db, claim=claim) is False  # the worker learns it must stop
    spec = make_spec(**{**SMALL, "seeds": 3})
    rows = queue.run_rows(claim.job_id, run_experiment(spec).runs)
    assert queue.store_runs(db, claim=claim, rows=rows, progress=1.0) is False  # and may not store results
    assert queue.finish(db, claim=claim, expected_runs=len(rows)) is False
    assert client.get(f"/api/jobs/{running['id']}").json()["status"] == "cancelled"

    assert client.delete(f"/api/jobs/{running['id']}", headers=JSON).status_code == 204
    assert client.get(f"/api/jobs/{running['id']}").status_code == 404


def test_patch_labels(client: TestClient) -> None:
    job = submit(client, name="a", tags=["x"])
    patched = client.patch(f"/api/jobs/{job['id']}", json={"tags": ["y", "z"], "notes": "hello"}).json()
    assert patched["tags"] == ["y", "z"] and patched["notes"] == "hello" and patched["name"] == "a"
    assert client.get("/api/jobs?tag=x").json()["count"] == 0
    assert client.get("/api/jobs?tag=z").json()["count"] == 1


@pytest.mark.parametrize("sort", ["-created_at", "created_at", "name", "-name", "status", "-status"])
def test_filters_sort_and_cursor_pagination(client: TestClient, sort: str) -> None:
    made = []
    for i in range(23):
        made.append(submit(client, name=f"job {i % 5}", tags=["even" if i % 2 == 0 else "odd"],
                           notes="needle" if i % 7 == 0 else "", system="single" if i % 3 else "multi"))
    for job in made[:6]:
        client.post(f"/api/jobs/{job['id']}/cancel", headers=JSON)

    def collect(query: str) -> tuple[list[dict], int]:
        seen: list[dict] = []
        cursor = None
        for _ in range(50):  # 23 jobs, 4 a page: a cursor that never ends fails here instead of looping forever
            url = f"/api/jobs?{query}&sort={sort}&limit=4" + (f"&cursor={cursor}" if cursor else "")
            page = client.get(url).json()
            seen += page["data"]
            count = page["count"]
            cursor = page["next_cursor"]
            if cursor is None:
                return seen, count
        raise AssertionError(f"still a next_cursor after 50 pages ({query!r}, sort {sort}): {len(seen)} rows")

    everything, count = collect("")
    assert count == 23 and len(everything) == 23 and len({j["id"] for j in everything}) == 23
    key = sort.lstrip("-")
    keys = [(j[key], j["id"]) for j in everything]
    assert keys == sorted(keys, reverse=sort.startswith("-"))

    odd, count = collect("tag=odd")
    assert count == len(odd) == 11 and all("odd" in j["tags"] for j in odd)
    found, _ = collect("q=NEEDLE")
    assert {j["id"] for j in found} == {made[i]["id"] for i in (0, 7, 14, 21)}
    multi, _ = collect("system=multi&status=queued")
    assert {j["id"] for j in multi} == {made[i]["id"] for i in (6, 9, 12, 15, 18, 21)}
    assert client.get("/api/jobs?q=even").json()["count"] == 12  # tags are searched too


def test_bad_cursor(client: TestClient) -> None:
    submit(client)
    response = client.get("/api/jobs?cursor=garbage")
    assert response.status_code == 422 and response.json()["detail"][0]["field"] == "cursor"


def test_compare_pools_seeds_by_configuration(client: TestClient, worker: Worker) -> None:
    a = submit(client, seeds=[0, 1, 2])
    b = submit(client, seeds=[2, 3], algorithms=["uniform", "mgrao-max"])
    c = submit(client, seeds=[0, 1], episodes=20)
    drain(worker)
    assert a["config_hash"] == b["config_hash"] != c["config_hash"]
    body = client.get(f"/api/compare?jobs={a['id']},{b['id']},{c['id']}&points=5").json()
    assert [j["id"] for j in body["jobs"]] == [a["id"], b["id"], c["id"]]
    assert [d["label"] for d in body["algorithms"]] == ["uniform", "mgrao-1:1", "mgrao-max"]  # described with it
    assert body["algorithms"][2] == describe_label("mgrao-max")
    groups = {(g["config_hash"], g["algorithm"]): g for g in body["groups"]}
    assert len(groups) == 6
    pooled = groups[(a["config_hash"], "mgrao-max")]
    assert pooled["job_ids"] == [a["id"], b["id"]] and pooled["summary"]["n_runs"] == 4  # seed 2 once
    assert groups[(a["config_hash"], "mgrao-1:1")]["summary"]["n_runs"] == 3
    assert groups[(c["config_hash"], "uniform")]["episodes_per_run"] == 20
    assert len(pooled["episodes"]["episode"]) == 5
    expected = run_experiment(make_spec("single", seeds=[0, 1, 2, 3], episodes=15)).summary()
    assert pooled["summary"] == expected["mgrao-max"].as_dict() | {"failure_rate": 0.0, "handover_rate": 0.0}
    assert client.get(f"/api/compare?jobs={a['id']},999").status_code == 404
    queued = submit(client)
    mixed = client.get(f"/api/compare?jobs={queued['id']},{c['id']}").json()
    assert len(mixed["jobs"]) == 2 and {g["config_hash"] for g in mixed["groups"]} == {c["config_hash"]}
    assert client.get(f"/api/compare?jobs={queued['id']}").json()["groups"] == []
    assert client.get("/api/compare?jobs=1,x").status_code == 422


def test_compare_keeps_its_groups_until_a_job_changes(client: TestClient, worker: Worker) -> None:
    from backend.services.analysis import RESULTS_CACHE

    done = submit(client, seeds=[0, 1])
    drain(worker)
    pending = submit(client, seeds=[2, 3])
    url = f"/api/compare?jobs={done['id']},{pending['id']}&points=5"
    builds = RESULTS_CACHE.builds
    first = client.get(url).json()
    assert client.get(url).json() == first and RESULTS_CACHE.builds == builds + 1  # the second is the kept answer
    assert [g["summary"]["n_runs"] for g in first["groups"]] == [2, 2, 2]
    client.patch(f"/api/jobs/{done['id']}", json={"name": "renamed"})
    renamed = client.get(url).json()
    assert renamed["jobs"][0]["name"] == "renamed" and renamed["groups"] == first["groups"]  # records read afresh
    assert RESULTS_CACHE.builds == builds + 1
    drain(worker)  # the pending job succeeds: its state is part of the key, so its seeds join the groups
    pooled = client.get(url).json()
    assert RESULTS_CACHE.builds == builds + 2
    assert [g["summary"]["n_runs"] for g in pooled["groups"]] == [4, 4, 4]
    assert client.get(f"/api/compare?jobs={pending['id']},{done['id']}&points=5").json()["jobs"][0]["id"] == \
        pending["id"]


@pytest.mark.parametrize(
    ("body", "field", "text"),
    [
        ({"params": {"n_parents": 2_000_000}}, "n_parents", "[1, 1000000]"),
        ({"params": {"bogus": 1}}, "bogus", "unknown parameter"),
        ({"params": {"n_types": "many"}}, "n_types", "must be a number"),
        ({"params": {"types_per_composite": 30}}, "types_per_composite", "n_types = 20"),
        ({"params": {"quality_model": "linear"}}, "quality_model", "hyperbolic, exponential, relative-linear"),
        ({"params": {"half_saturation": 0}}, "half_saturation", "[0.001, 10]"),
        ({"params": {"half_saturation": 50.0}}, "half_saturation", "[0.001, 10]"),
        ({"params": {"load_sharing": "sometimes"}}, "load_sharing", "true or false"),
        ({"params": {"routing": "random"}}, "routing", "per-composite, per-task"),
        ({"params": {"absent_tasks": "dropped"}}, "absent_tasks", "excluded, counted"),
        ({"params": {"absent_quality": 2}}, "absent_quality", "[0, 1]"),
        ({"params": {"temperature": 1e-310}}, "temperature", "[0.0001, 100]"),
        ({"episodes": MAX_EPISODES + 1}, "episodes", "100000"),
        ({"episodes": 0}, "episodes", "must be at least 1 (got 0)"),
        ({"seeds": 1001}, "seeds", "1000"),
        ({"seeds": [1, 1]}, "seeds", "repeat"),
        ({"seeds": [1, -2]}, "seeds[1]", "must be at least 0 (got -2)"),
        ({"seeds": list(range(1001))}, "seeds", "1000"),
        ({"system": "nope"}, "system", "single, multi, volatile, large"),
        ({"algorithms": ["uniform", "mgrao-3:1"]}, "algorithms[1]", ""),
        ({"algorithms": ["uniform"] * 21}, "algorithms", "20"),
        ({"algorithms": []}, "algorithms", "at least 1"),
        ({"system": "large", "seeds": 1000, "episodes": 10000}, "work", "2,000,000,000"),
        ({"name": "n" * 201}, "name", "200"),
        ({"tags": ["t"] * 21}, "tags", "20"),
        ({"surprise": 1}, "surprise", "is not a field of this body"),
        ({"episodes": True}, "episodes", "must be a whole number (got true)"),
    ],
)
def test_bad_input_is_422_naming_the_field_and_limit(client: TestClient, body: dict, field: str,
                                                      text: str) -> None:
    response = client.post("/api/jobs", json={**SMALL, **body})
    assert response.status_code == 422, response.text
    detail = response.json()["detail"]
    assert detail[0]["field"] == field and text in detail[0]["msg"] and detail[0]["msg"].startswith(field)
    assert detail[0]["loc"][0] == "body"


def test_param_error_loc_points_into_params(client: TestClient) -> None:
    detail = client.post("/api/jobs", json={**SMALL, "params": {"n_parents": 2_000_000}}).json()["detail"][0]
    assert detail["loc"] == ["body", "params", "n_parents"]
    assert detail["msg"] == "n_parents: must be in [1, 1000000] (got 2000000)"


@pytest.mark.parametrize(
    "url",
    ["/api/jobs?limit=0", "/api/jobs?limit=201", "/api/jobs?sort=bogus", "/api/jobs?status=done",
     "/api/jobs/1/results?points=0", "/api/jobs/1/episodes?format=xml", "/api/compare?jobs=" + ",".join(["1"] * 51)],
)
def test_bad_query_is_422(client: TestClient, url: str) -> None:
    response = client.get(url)
    assert response.status_code == 422
    assert response.json()["detail"][0]["loc"][0] == "query"


def test_body_over_limit_is_413(client: TestClient) -> None:
    big = {**SMALL, "notes": "x" * 70_000}
    assert client.post("/api/jobs", json=big).status_code == 413
    assert client.post("/api/jobs", content=b"{" * 70_000, headers={"content-type": "application/json"}
                       ).status_code == 413


@pytest.mark.parametrize(
    ("method", "path"),
    [("get", "/api/jobs/999"), ("patch", "/api/jobs/999"), ("post", "/api/jobs/999/cancel"),
     ("delete", "/api/jobs/999"), ("get", "/api/jobs/999/results"), ("get", "/api/jobs/999/episodes")],
)
def test_unknown_ids_are_404(client: TestClient, method: str, path: str) -> None:
    kwargs = {"json": {"name": "x"}} if method == "patch" else {"headers": JSON}
    assert getattr(client, method)(path, **kwargs).status_code == 404


def test_auth_on_mutating_routes(auth_client: TestClient) -> None:
    assert auth_client.post("/api/jobs", json=SMALL).status_code == 401
    wrong = {"Authorization": "Bearer nope"}
    assert auth_client.post("/api/jobs", json=SMALL, headers=wrong).status_code == 401
    good = {"Authorization": f"Bearer {TOKEN}"}
    job = auth_client.post("/api/jobs", json=SMALL, headers=good).json()
    for method, path in [("patch", f"/api/jobs/{job['id']}"), ("post", f"/api/jobs/{job['id']}/cancel"),
                         ("delete", f"/api/jobs/{job['id']}")]:
        kwargs = {"json": {"name": "y"}} if method == "patch" else {"headers": JSON}
        assert getattr(auth_client, method)(path, **kwargs).status_code == 401
    assert auth_client.get("/api/jobs").status_code == 200  # reads stay open
    assert auth_client.get(f"/api/jobs/{job['id']}").status_code == 200
    assert auth_client.post(f"/api/jobs/{job['id']}/cancel", headers={**good, **JSON}).status_code == 200
    assert auth_client.delete(f"/api/jobs/{job['id']}", headers={**good, **JSON}).status_code == 204


def test_auth_off_accepts_anonymous_writes(client: TestClient) -> None:
    assert client.post("/api/jobs", json=SMALL).status_code == 202


def test_systems_health_and_static(client: TestClient) -> None:
    systems = client.get("/api/systems").json()
    assert [s["name"] for s in systems["systems"]] == list(PRESETS)
    assert systems["limits"]["max_body_bytes"] == 65536 and systems["limits"]["max_seeds"] == 1000
    assert {p["name"] for p in systems["parameters"]} >= {"n_types", "n_parents"}
    submit(client)
    assert client.get("/api/health").json() == {"status": "ok", "version": "0.1.0", "database": "ok",
                                                "queued": 1, "running": 0, "workers": {"warming": 0, "ready": 0}}
    plotly = client.get("/vendor/plotly.min.js")
    assert plotly.status_code == 200 and len(plotly.content) > 1_000_000
    assert client.get("/openapi.json").json()["paths"]["/api/jobs"]["post"]["summary"]
    assert client.get("/docs").status_code == 200
    index = client.get("/")
    assert index.status_code in (200, 404)  # the dashboard may not be written yet
    if index.status_code == 200:
        assert "<html" in index.text.lower()
    static = frontend_dir()
    for name in ("js/app.js", "style.css"):
        if static is not None and (static / name).exists():
            assert client.get(f"/{name}").status_code == 200
    assert client.get("/api/nothing-here").status_code == 404


def test_delete_removes_the_runs(client: TestClient, worker: Worker, db: Database) -> None:
    job = submit(client)
    drain(worker)
    with db.session() as session:
        assert session.scalar(select(func.count()).select_from(Run)) == 9
    assert client.delete(f"/api/jobs/{job['id']}", headers=JSON).status_code == 204
    with db.session() as session:
        assert session.scalar(select(func.count()).select_from(Run)) == 0
    assert client.get(f"/api/jobs/{job['id']}/episodes").status_code == 404


def test_paper_figures_for_the_papers_own_experiment(client: TestClient, worker: Worker) -> None:
    job = submit(client, seeds=2, episodes=100)
    assert drain(worker) == 1
    assert client.get(f"/api/jobs/{job['id']}/results").json()["paper"] == {"mgrao-1:1": 23.4, "mgrao-max": 28.0}


def test_new_environment_parameters_are_accepted_and_stored_resolved(client: TestClient) -> None:
    body = {**SMALL, "params": {"load_sharing": True, "quality_model": "exponential", "routing": "per-task"}}
    job = client.post("/api/jobs", json=body).json()
    params = client.get(f"/api/jobs/{job['id']}").json()["params"]
    assert (params["load_sharing"], params["quality_model"], params["routing"]) == (True, "exponential", "per-task")
    assert params["half_saturation"] == 0.2 and params["absent_tasks"] == "excluded"
    schema = {p["name"]: p for p in client.get("/api/systems").json()["parameters"]}
    assert schema["load_sharing"]["kind"] == "bool" and schema["quality_model"]["default"] == "hyperbolic"


def test_a_number_of_hundreds_of_digits_is_422_not_500(client: TestClient) -> None:
    body = '{"system": "single", "seeds": 2, "episodes": 3, "params": {"learning_rate": 1' + "0" * 400 + "}}"
    response = client.post("/api/jobs", content=body, headers={"Content-Type": "application/json"})
    assert response.status_code == 422, response.text
    assert response.json()["detail"][0]["field"] == "learning_rate"


def test_an_unexpected_error_is_a_json_500_with_the_security_headers(settings) -> None:
    from backend.api.app import create_app

    app = create_app(settings)

    def boom() -> None:
        raise RuntimeError("a bug")

    app.add_api_route("/api/test-only-boom", boom)
    app.router.routes.insert(0, app.router.routes.pop())  # before the dashboard's mount at "/"

    with TestClient(app, base_url="http://127.0.0.1", raise_server_exceptions=False) as local:
        response = local.get("/api/test-only-boom")
        assert response.status_code == 500
        assert response.json() == {"detail": "internal error (RuntimeError); see the service log"}
        assert "default-src" in response.headers["content-security-policy"]
        assert response.headers["x-content-type-options"] == "nosniff"
        assert local.get("/api/health").status_code == 200  # the service goes on


def test_a_deleted_jobs_id_is_never_given_to_a_new_job(client: TestClient) -> None:
    first = submit(client)["id"]
    newest = submit(client)["id"]
    assert client.delete(f"/api/jobs/{newest}", headers={"Content-Type": "application/json"}).status_code == 204
    again = submit(client)["id"]
    assert again > newest > first


def test_a_stale_period_shorter_than_two_heartbeats_is_refused_naming_both() -> None:
    from pydantic import ValidationError

    from backend.settings import Settings

    with pytest.raises(ValidationError, match="MGRAO_STALE_AFTER_S .5. must be at least twice MGRAO_HEARTBEAT_S .5."):
        Settings(stale_after_s=5, heartbeat_s=5)
