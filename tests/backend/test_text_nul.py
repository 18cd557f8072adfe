"""A NUL character in any text that comes in answers 422 naming the field, on SQLite and PostgreSQL alike.

PostgreSQL cannot store it (500 before), SQLite stored it, and ``q=%00`` matched every job there.
Against a real ``mgrao serve`` on each database.
"""

from __future__ import annotations

import base64
import json

import httpx
from backend_helpers import JSON, Service

NUL = "\x00"
JOB = {"system": "single", "seeds": 1, "episodes": 2}
STUDY = {"name": "s", "base": {"system": "single", "seeds": 1, "episodes": 2},
         "space": {"learning_rate": {"values": [0.1, 0.2]}},
         "objective": {"configuration": "mgrao-max", "metric": "final_mean"}}

BODIES = [  # (method, path, body, field); {id} is a job's id, {study} a study's
    ("POST", "/api/jobs", JOB | {"name": f"a{NUL}b"}, "name"),
    ("POST", "/api/jobs", JOB | {"tags": ["ok", NUL]}, "tags[1]"),
    ("POST", "/api/jobs", JOB | {"notes": f"notes{NUL}"}, "notes"),
    ("POST", "/api/jobs", JOB | {"system": f"single{NUL}"}, "system"),
    ("POST", "/api/jobs", JOB | {"algorithms": ["uniform", f"mgrao-max{NUL}"]}, "algorithms[1]"),
    ("POST", "/api/jobs", JOB | {"params": {"quality_model": NUL}}, "quality_model"),
    ("POST", "/api/jobs", JOB | {"params": {f"n_types{NUL}": 3}}, "params"),
    ("PATCH", "/api/jobs/{id}", {"name": NUL}, "name"),
    ("PATCH", "/api/jobs/{id}", {"tags": [f"t{NUL}"]}, "tags[0]"),
    ("PATCH", "/api/jobs/{id}", {"notes": f"{NUL}x"}, "notes"),
    ("POST", "/api/studies", STUDY | {"name": f"study{NUL}"}, "name"),
    ("POST", "/api/studies", STUDY | {"base": STUDY["base"] | {"params": {"routing": NUL}}}, "base.params.routing"),
    ("POST", "/api/studies", STUDY | {"space": {"quality_model": {"values": [f"a{NUL}"]}}},
     "space.quality_model.values[0]"),
]


def cursor(*content: object) -> str:
    return base64.urlsafe_b64encode(json.dumps(list(content)).encode()).decode().rstrip("=")


QUERIES = [  # (path, params, field)
    ("/api/jobs", {"q": NUL}, "q"),
    ("/api/jobs", {"q": f"base{NUL}"}, "q"),
    ("/api/jobs", {"tag": f"paper{NUL}"}, "tag"),
    ("/api/jobs", {"system": f"single{NUL}"}, "system"),
    ("/api/jobs", {"sort": f"name{NUL}"}, "sort"),
    ("/api/jobs", {"sort": "name", "cursor": f"abc{NUL}"}, "cursor"),
    ("/api/jobs", {"sort": "name", "cursor": cursor("name", f"a{NUL}", 1)}, "cursor"),  # a crafted cursor's key
    ("/api/studies", {"q": NUL}, "q"),
    ("/api/studies", {"cursor": f"x{NUL}"}, "cursor"),
    ("/api/studies/{study}/plots", {"x": NUL}, "x"),
    ("/api/studies/{study}/plots", {"y": f"learning_rate{NUL}"}, "y"),
    ("/api/compare", {"jobs": f"{{id}}{NUL}"}, "jobs"),
]


def assert_names(response, field: str, where: str) -> None:
    assert response.status_code == 422, f"{where}: {response.status_code} {response.text}"
    details = response.json()["detail"]
    assert [d["field"] for d in details] == [field], f"{where}: {details}"
    assert details[0]["msg"].startswith(f"{field}: "), details
    assert "NUL" in details[0]["msg"] or field == "cursor", details


def test_nul_in_any_text_answers_422_naming_the_field(service: Service) -> None:
    service.start_server()
    job = service.post("/api/jobs", json=JOB | {"name": "base", "tags": ["paper"]}, headers=JSON).json()
    study = service.post("/api/studies", json=STUDY, headers=JSON)
    assert study.status_code == 202, study.text
    ids = {"id": job["id"], "study": study.json()["study"]["id"]}

    for method, path, body, field in BODIES:
        response = httpx.request(method, service.base + path.format(**ids), json=body, headers=JSON, timeout=30)
        assert_names(response, field, f"{method} {path} {body}")
    for path, params, field in QUERIES:
        params = {k: v.format(**ids) if k == "jobs" else v for k, v in params.items()}
        assert_names(service.get(path.format(**ids), params=params), field, f"GET {path} {params!r}")

    # nothing was stored or changed, and the listings still work (a NUL in q no longer matches every job)
    assert service.get("/api/jobs").json()["count"] == 3  # the job and the study's two trials
    after = service.get(f"/api/jobs/{job['id']}").json()
    assert (after["name"], after["tags"], after["notes"]) == ("base", ["paper"], "")
    assert service.get("/api/studies").json()["count"] == 1
    assert [j["id"] for j in service.get("/api/jobs", params={"q": "base"}).json()["data"]] == [job["id"]]
