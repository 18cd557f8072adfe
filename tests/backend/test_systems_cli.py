"""``mgrao systems save/list/export/delete`` against the app (in-process, through its test client)."""

from __future__ import annotations

import json
from collections.abc import Iterator

import click
import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient

import mgrao_cli.systems as systems_cli
from mgrao_cli.main import cli
from tests.support.extra_params import registered

SCHEDULE = [{"episode": 3, "change": "new-profiles", "fraction": 0.5}]


@pytest.fixture(autouse=True)
def _through_the_app(monkeypatch: pytest.MonkeyPatch, client: TestClient) -> Iterator[None]:
    class Api:
        def __init__(self, url: str, token: str | None) -> None:
            pass

        def call(self, method: str, path: str, body=None):
            response = client.request(method, path, json=body, headers={"Content-Type": "application/json"})
            if response.status_code >= 400:
                raise click.ClickException("\n".join(d["msg"] for d in response.json()["detail"])
                                           if isinstance(response.json()["detail"], list) else response.text)
            return response.json() if response.content else None

    monkeypatch.setattr(systems_cli, "Api", Api)
    with registered(monkeypatch):
        yield


def _mgrao(*args: str):
    return CliRunner().invoke(cli, ["systems", *args], catch_exceptions=False)


def test_save_list_export_and_run_the_file(tmp_path) -> None:
    done = _mgrao("save", "rush", "--from", "single", "--set", "n_parents=12",
                  "--set", f"example_schedule={json.dumps(SCHEDULE)}", "--description", "a shift at 3")
    assert done.exit_code == 0, done.output
    assert "saved rush: single with n_parents=12" in done.output
    listed = _mgrao("list")
    assert listed.output.startswith("rush\tsingle\t") and "a shift at 3" in listed.output
    out = tmp_path / "rush.json"
    assert _mgrao("export", "rush", "--out", str(out)).exit_code == 0
    exported = json.loads(out.read_text())
    assert exported == {"name": "rush", "description": "a shift at 3", "base": "single",
                        "params": {"n_parents": 12, "example_schedule": SCHEDULE}}
    ran = CliRunner().invoke(cli, ["run", "--params-file", str(out), "--seeds", "1", "--episodes", "4",
                                   "--format", "json"], catch_exceptions=False)
    assert ran.exit_code == 0, ran.output
    assert json.loads(ran.stdout)["spec"]["params"]["example_schedule"] == SCHEDULE
    exported["name"] = "rush-copy"
    out.write_text(json.dumps(exported))
    assert _mgrao("save", "rush-copy", "--file", str(out)).exit_code == 0
    assert "a shift at 3" in _mgrao("list").output.splitlines()[1]
    assert _mgrao("save", "rush", "--from", "multi", "--replace").exit_code == 0
    assert "rush\tmulti\tno overrides" in _mgrao("list").output
    assert _mgrao("delete", "rush").output == "deleted rush\n"


def test_a_refused_value_is_named() -> None:
    done = _mgrao("save", "bad", "--set", 'example_schedule=[{"episode": 1, "fraction": 3}]')
    assert done.exit_code == 1 and "example_schedule[0].fraction: must be in [0, 1] (got 3)" in done.output
