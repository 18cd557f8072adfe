"""``MGRAO_PROTECT_READS``: every read of data needs the bearer token too, against a real ``mgrao serve``.

The GET routes checked are those of the app's own OpenAPI document, so a route added later is
checked without a change here. Without the setting, reads stay open (tests/backend/test_security.py
and the rest of the suite run that way).
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import httpx
import pytest
from backend_helpers import BASE_URL, JSON, TOKEN, Service
from fastapi.testclient import TestClient
from pydantic import ValidationError

from backend.api.app import create_app
from backend.settings import Settings
from tests.support.local_service import free_port, mgrao_command, serve_command

pytestmark = pytest.mark.slow

GOOD = {"Authorization": f"Bearer {TOKEN}"}
WRONG = [{}, {"Authorization": "Bearer not-the-token"}, {"Authorization": f"Basic {TOKEN}"},
         {"Authorization": TOKEN}, {"Authorization": f"Bearer {TOKEN}x"}]
SMALL_JOB = {"system": "single", "seeds": 1, "episodes": 5, "name": "private"}
SMALL_STUDY = {
    "name": "private study", "method": "grid",
    "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 1, "episodes": 5},
    "space": {"learning_rate": {"values": [0.1, 0.2]}},
    "objective": {"configuration": "mgrao-max", "metric": "final_mean", "direction": "maximize"},
}
STATIC_SHELL = ["/", "/index.html", "/js/api.js", "/js/tokenform.js", "/style.css", "/favicon.svg",
                "/docs/swagger-init.js"]


def protected(service: Service) -> Service:
    """``service`` with a token and protected reads, its server started (no workers: jobs stay queued)."""
    service.env |= {"MGRAO_API_TOKEN": TOKEN, "MGRAO_PROTECT_READS": "true"}
    service.start_server(workers=0)
    return service


def get_routes(service: Service) -> list[str]:
    """Every GET path of the served app's OpenAPI document."""
    document = service.get("/openapi.json", headers=GOOD).json()
    return sorted(path for path, operations in document["paths"].items() if "get" in operations)


def concrete(path: str, job_id: int, study_id: int) -> str:
    """``path`` with its parameters filled: a study's id for ``{study...}``, else the job's."""
    return re.sub(r"\{([^}]+)\}", lambda m: str(study_id if m.group(1).startswith("study") else job_id), path)


def test_every_get_route_needs_the_token(service: Service) -> None:
    protected(service)
    job = service.post("/api/jobs", json=SMALL_JOB, headers=GOOD)
    study = service.post("/api/studies", json=SMALL_STUDY, headers=GOOD)
    assert job.status_code == 202 and study.status_code == 202, (job.text, study.text)
    job_id, study_id = job.json()["id"], study.json()["study"]["id"]

    routes = get_routes(service)
    assert {"/api/jobs", "/api/jobs/{job_id}", "/api/jobs/{job_id}/episodes", "/api/studies",
            "/api/studies/{study_id}", "/api/compare", "/api/systems"} <= set(routes), routes
    for route in routes:
        path = concrete(route, job_id, study_id)
        for headers in WRONG if route != "/api/health" else []:
            refused = service.get(path, headers=headers)
            assert refused.status_code == 401, (path, headers, refused.text)
            assert refused.headers["www-authenticate"] == "Bearer"
            assert "bearer token" in refused.json()["detail"] and "private" not in refused.text
        answered = service.get(path, headers=GOOD)
        assert answered.status_code != 401 and answered.status_code < 500, (path, answered.text)
    assert "private" in [j["name"] for j in service.get("/api/jobs", headers=GOOD).json()["data"]]
    assert service.get(f"/api/jobs/{job_id}", headers={"Authorization": f"bearer {TOKEN}"}).status_code == 200


def test_schema_docs_health_writes_and_the_static_shell(service: Service) -> None:
    protected(service)
    for path in ["/openapi.json", "/docs", "/redoc", "/api", "/api/", "/api/jobs/", "/api/no-such-route"]:
        for headers in WRONG:
            assert service.get(path, headers=headers).status_code == 401, (path, headers)
    assert "/api/jobs" in service.get("/openapi.json", headers=GOOD).json()["paths"]
    assert "swagger-ui" in service.get("/docs", headers=GOOD).text
    for path in STATIC_SHELL:  # no data in them: the page can load and ask for the token
        assert service.get(path).status_code == 200, path

    for headers in WRONG:  # open, but its status alone: nothing on the queue, workers or database
        health = service.get("/api/health", headers=headers)
        assert health.status_code == 200 and health.json() == {"status": "ok"}, health.text
    full = service.get("/api/health", headers=GOOD).json()
    assert full["status"] == "ok" and {"version", "database", "queued", "running", "workers"} <= set(full)

    for headers in WRONG:  # writes: refused as before, and nothing stored
        written = service.post("/api/jobs", json=SMALL_JOB, headers=headers)
        assert written.status_code == 401, written.text
    assert service.post("/api/jobs", json=SMALL_JOB, headers=GOOD).status_code == 202
    assert service.get("/api/jobs", headers=GOOD).json()["count"] == 1
    # refusals that come first stay as they were: a foreign origin, a body that is not JSON
    assert service.post("/api/jobs/1/cancel", headers={"Origin": "http://evil.example"}).status_code == 403
    assert service.post("/api/jobs/1/cancel", headers={"Content-Type": "text/plain"}).status_code == 415


def test_health_without_the_token_hides_why_the_database_failed(tmp_path: Path) -> None:
    db_file = tmp_path / "gone.db"
    settings = Settings(database_url=f"sqlite:///{db_file}", api_token=TOKEN, protect_reads=True)
    with TestClient(create_app(settings), base_url=BASE_URL) as client:
        assert client.get("/api/health").json() == {"status": "ok"}
        db_file.unlink()
        hidden = client.get("/api/health")
        assert hidden.status_code == 503 and hidden.json() == {"status": "error"}, hidden.text
        assert hidden.headers["retry-after"] == "5"
        shown = client.get("/api/health", headers=GOOD)
        assert shown.status_code == 503 and "missing" in shown.json()["database"], shown.text


def test_protected_reads_without_a_token_are_refused_at_start(tmp_path: Path) -> None:
    for token in (None, ""):
        with pytest.raises(ValidationError, match="MGRAO_PROTECT_READS=true needs MGRAO_API_TOKEN"):
            Settings(database_url="sqlite:///unused.db", api_token=token, protect_reads=True)
    assert Settings(database_url="sqlite:///unused.db", api_token=TOKEN, protect_reads=True).protect_reads
    assert not Settings(database_url="sqlite:///unused.db").protect_reads

    db_file = tmp_path / "never.db"
    env = {k: v for k, v in Service(tmp_path).env.items() if k != "MGRAO_API_TOKEN"} | {"MGRAO_PROTECT_READS": "1"}
    done = subprocess.run(serve_command(free_port(), 0, f"sqlite:///{db_file}"), env=env, capture_output=True,
                          text=True, timeout=60, check=False)
    assert done.returncode == 1, done.stderr
    assert "Error: invalid settings: MGRAO_PROTECT_READS=true needs MGRAO_API_TOKEN" in done.stderr
    assert "Traceback" not in done.stderr and not db_file.exists()


def test_study_commands_send_the_token(tmp_path: Path) -> None:
    service = Service(tmp_path)
    try:
        protected(service)
        study = tmp_path / "study.json"
        study.write_text(httpx.Request("POST", "/", json=SMALL_STUDY).content.decode())
        without = {k: v for k, v in service.env.items() if k != "MGRAO_API_TOKEN"}

        def mgrao(*args: str, env: dict[str, str] = without) -> subprocess.CompletedProcess:
            return subprocess.run(mgrao_command("study", *args, "--url", service.base), env=env, capture_output=True,
                                  text=True, timeout=120, check=False)

        refused = mgrao("run", str(study), "--detach")
        assert refused.returncode == 1 and "needs its API token: pass --token" in refused.stderr, refused.stderr
        submitted = mgrao("run", str(study), "--detach", "--token", TOKEN)
        assert submitted.returncode == 0, submitted.stderr
        study_id = submitted.stdout.strip()
        refused = mgrao("show", study_id)
        assert refused.returncode == 1 and "needs its API token: pass --token" in refused.stderr, refused.stderr
        assert mgrao("show", study_id, "--token", "wrong").returncode == 1
        by_option = mgrao("show", study_id, "--token", TOKEN)
        assert by_option.returncode == 0, by_option.stderr
        assert by_option.stdout.startswith(f"study {study_id} 'private study': grid, running")
        by_env = mgrao("show", study_id, "--json", env=service.env)  # MGRAO_API_TOKEN
        assert by_env.returncode == 0, by_env.stderr
        assert '"name": "private study"' in by_env.stdout
    finally:
        service.stop()


def test_setting_off_keeps_reads_open(tmp_path: Path) -> None:
    """The default, token or not: reads and the schema answer without it, health with every detail."""
    settings = Settings(database_url=f"sqlite:///{tmp_path / 'open.db'}", api_token=TOKEN)
    with TestClient(create_app(settings), base_url=BASE_URL) as client:
        assert client.post("/api/jobs", json=SMALL_JOB, headers=JSON).status_code == 401
        for path in ["/api/jobs", "/api/systems", "/api/studies", "/openapi.json", "/docs"]:
            assert client.get(path).status_code == 200, path
        assert {"version", "queued", "workers"} <= set(client.get("/api/health").json())
