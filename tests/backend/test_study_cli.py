"""``mgrao study run`` and ``mgrao study show`` against a real ``mgrao serve`` with a worker."""

from __future__ import annotations

import json
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from backend_helpers import Service

from tests.support.local_service import free_port, mgrao_command

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def sqlite_service(tmp_path: Path) -> Iterator[Service]:
    svc = Service(tmp_path)
    svc.env["MGRAO_STUDY_POLL_S"] = "0.3"
    svc.start_server(workers=1)
    yield svc
    svc.stop()


def mgrao(service: Service, *args: str, timeout: float = 240) -> subprocess.CompletedProcess:
    return subprocess.run(mgrao_command(*args), env=service.env, capture_output=True, text=True, timeout=timeout,
                          check=False)


def test_study_run_follows_the_study_and_prints_the_best_trials(sqlite_service: Service, tmp_path: Path) -> None:
    study = json.loads((ROOT / "studies" / "single-sensitivity.json").read_text())
    study["base"] |= {"seeds": 2, "episodes": 20}  # the example's shape, smaller
    study["space"] = {"learning_rate": {"low": 0.05, "high": 0.2, "steps": 2, "log": True},
                      "trace_decay": {"values": [0.5, 0.9]}}
    study["max_trials"] = 4
    path = tmp_path / "study.json"
    path.write_text(json.dumps(study))
    done = mgrao(sqlite_service, "study", "run", str(path), "--url", sqlite_service.base, "--poll", "0.2",
                 "--top", "3")
    assert done.returncode == 0, done.stderr
    assert "4 trials planned" in done.stderr
    lines = done.stdout.splitlines()
    assert "grid, finished; 4 succeeded of 4 planned" in lines[0]
    assert lines[1] == "objective: maximize pct_from_uniform of mgrao-max"
    header = lines[3].split()
    assert header[:3] == ["trial", "learning_rate", "trace_decay"]
    answer = sqlite_service.get("/api/studies/1").json()
    best = sorted((t for t in answer["trials"]), key=lambda t: -t["value"])[:3]
    assert [int(row.split()[0]) for row in lines[4:7]] == [t["number"] for t in best]
    assert lines[-1] == f"dashboard: {sqlite_service.base}/#/studies/1"

    shown = mgrao(sqlite_service, "study", "show", "1", "--url", sqlite_service.base, "--top", "3")
    assert shown.returncode == 0 and shown.stdout == done.stdout
    as_json = json.loads(mgrao(sqlite_service, "study", "show", "1", "--url", sqlite_service.base, "--json").stdout)
    assert as_json["study"]["best_value"] == best[0]["value"]


def test_study_run_reports_the_field_the_service_refused(sqlite_service: Service, tmp_path: Path) -> None:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps({"base": {"system": "single"}, "space": {"learning_rate": {"low": 0.5, "high": 0.1,
                                                                                         "steps": 3}},
                                "objective": {"configuration": "mgrao-max", "metric": "final_mean"}}))
    done = mgrao(sqlite_service, "study", "run", str(path), "--url", sqlite_service.base)
    assert done.returncode == 1
    assert "space.learning_rate: low must be below high (got 0.5 and 0.1)" in done.stderr
    assert sqlite_service.get("/api/studies").json()["count"] == 0
    path.write_text("{not json")
    done = mgrao(sqlite_service, "study", "run", str(path), "--url", sqlite_service.base)
    assert done.returncode == 1 and "is not JSON" in done.stderr


def test_study_commands_say_when_no_service_answers(tmp_path: Path) -> None:
    url = f"http://127.0.0.1:{free_port()}"
    done = subprocess.run(mgrao_command("study", "show", "1", "--url", url), capture_output=True, text=True,
                          timeout=60, check=False)
    assert done.returncode == 1
    assert f"no MG-RAO service answers at {url}" in done.stderr and "mgrao serve" in done.stderr
