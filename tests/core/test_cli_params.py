"""``mgrao run`` with list and event-list values: ``--set name='[...]'`` (JSON) and ``--params-file``.

The parameters are the look-alikes of tests/support/extra_params.py, registered in this process.
"""

import json

import pytest
from click.testing import CliRunner

from mgrao_cli.main import cli
from tests.support.extra_params import registered

SCHEDULE = [{"episode": 1, "change": "new-profiles", "fraction": 0.5}]


@pytest.fixture(autouse=True)
def _examples(monkeypatch):
    with registered(monkeypatch):
        yield


def _run(*args):
    return CliRunner().invoke(cli, ["run", "--seeds", "1", "--episodes", "3", "--format", "json", *args],
                              catch_exceptions=False)


def test_set_takes_json_lists_and_event_lists():
    result = _run("--system", "single", "--set", f"example_schedule={json.dumps(SCHEDULE)}",
                  "--set", "example_periods=[2, 3]")
    assert result.exit_code == 0, result.output
    params = json.loads(result.stdout)["spec"]["params"]
    assert params["example_schedule"] == SCHEDULE and params["example_periods"] == [2, 3]


def test_a_bad_field_is_named():
    result = _run("--system", "single", "--set", 'example_schedule=[{"episode": 1, "fraction": 2}]')
    assert result.exit_code == 2
    assert "example_schedule[0].fraction: must be in [0, 1] (got 2)" in result.output
    result = _run("--system", "single", "--set", "example_periods=[1,")
    assert result.exit_code == 2 and "example_periods: must be a JSON list" in result.output


def test_params_file_of_values_and_set_on_top(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"example_schedule": SCHEDULE, "n_parents": 12}))
    result = _run("--system", "single", "--params-file", str(path), "--set", "n_parents=14")
    assert result.exit_code == 0, result.output
    spec = json.loads(result.stdout)["spec"]
    assert spec["params"]["example_schedule"] == SCHEDULE and spec["params"]["n_parents"] == 14


def test_params_file_of_a_saved_system_gives_its_base(tmp_path):
    path = tmp_path / "s.json"
    path.write_text(json.dumps({"name": "rush", "description": "", "base": "multi", "params": {"n_children": 2}}))
    result = _run("--params-file", str(path))
    assert result.exit_code == 0, result.output
    spec = json.loads(result.stdout)["spec"]
    assert spec["system"] == "multi" and spec["params"]["n_children"] == 2


def test_params_file_errors(tmp_path):
    assert "give --system" in _run("--params-file", str(_write(tmp_path, "{}"))).output
    assert "not JSON" in _run("--system", "single", "--params-file", str(_write(tmp_path, "{"))).output
    assert "JSON object" in _run("--system", "single", "--params-file", str(_write(tmp_path, "[1]"))).output


def _write(tmp_path, text):
    path = tmp_path / "f.json"
    path.write_text(text)
    return path
