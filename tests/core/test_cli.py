"""The ``mgrao`` command line, through click's test runner."""

import csv
import io
import json
import subprocess
import sys

import pytest
from click.testing import CliRunner

from mgrao_cli.main import cli


@pytest.fixture
def runner():
    return CliRunner()


def _run(runner, *args):
    return runner.invoke(cli, list(args), catch_exceptions=False)


def test_run_json(runner):
    result = _run(runner, "run", "--system", "single", "--seeds", "2", "--episodes", "12", "--format", "json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["spec"]["system"] == "single"
    assert data["spec"]["seeds"] == [0, 1]
    assert set(data["summary"]) == {"uniform", "mgrao-1:1", "mgrao-max"}
    assert data["summary"]["uniform"]["pct_from_uniform"] == 0.0
    assert len(data["runs"]) == 6
    assert len(data["runs"][0]["utilities"]) == 12
    for summary in [*data["summary"].values(), *data["runs"]]:  # nothing can fail: 0, never null
        assert summary["failure_rate"] == summary["handover_rate"] == 0.0


def test_run_json_and_table_give_what_became_of_tasks_that_can_fail(runner):
    args = ["run", "--system", "multi", "--algorithms", "uniform,mgrao-1:1", "--seeds", "2", "--episodes", "10",
            "--set", "task_need=1.5", "--set", "hierarchy=hand-over"]
    data = json.loads(_run(runner, *args, "--format", "json").stdout)  # stdout holds only the JSON
    from mgrao_core import make_spec, run_experiment

    expected = run_experiment(make_spec("multi", ["uniform", "mgrao-1:1"], seeds=2, episodes=10,
                                        overrides={"task_need": 1.5, "hierarchy": "hand-over"})).task_counts()
    for label, counts in expected.items():
        assert data["summary"][label]["failure_rate"] == counts.failure_rate > 0
        assert data["summary"][label]["handover_rate"] == counts.handover_rate > 0
    table = _run(runner, *args).stdout
    assert "% failed" in table and "% by a neighbour" in table
    assert f"{100 * expected['uniform'].failure_rate:.1f}" in table


def test_run_csv(runner):
    result = _run(runner, "run", "--system", "multi", "--algorithms", "uniform,mgrao-2:1", "--seeds", "2",
                  "--episodes", "4", "--format", "csv")
    assert result.exit_code == 0, result.output
    rows = [r for r in csv.reader(io.StringIO(result.stdout)) if r]
    assert rows[0] == ["algorithm", "seed", "episode", "utility"]
    assert len(rows) == 1 + 2 * 2 * 4
    assert {r[0] for r in rows[1:]} == {"uniform", "mgrao-2:1"}
    assert all(float(r[3]) >= 0 for r in rows[1:])


def test_run_table(runner):
    result = _run(runner, "run", "--system", "single", "--seeds", "3", "--episodes", "12")
    assert result.exit_code == 0, result.output
    assert "% from uniform" in result.stdout
    assert "mgrao-max" in result.stdout
    assert "3 seeds x 12 episodes" in result.stdout


def test_run_set_overrides_parameters(runner):
    result = _run(runner, "run", "--system", "single", "--seeds", "1", "--episodes", "3", "--format", "json",
                  "--set", "temperature=1", "--set", "n_parents = 20")
    assert result.exit_code == 0, result.output
    params = json.loads(result.stdout)["spec"]["params"]
    assert params["temperature"] == 1.0
    assert params["n_parents"] == 20


def test_run_out_file(runner, tmp_path):
    out = tmp_path / "result.json"
    result = _run(runner, "run", "--system", "single", "--seeds", "1", "--episodes", "3", "--format", "json",
                  "--out", str(out))
    assert result.exit_code == 0, result.output
    assert result.stdout == ""
    assert json.loads(out.read_text())["spec"]["episodes"] == 3


def test_bad_set_without_equals(runner):
    result = _run(runner, "run", "--system", "single", "--set", "temperature")
    assert result.exit_code == 2
    assert "--set" in result.output
    assert "name=value" in result.output


@pytest.mark.parametrize(("setting", "text"), [
    ("n_parents=0", "n_parents"), ("bogus=1", "bogus"), ("n_types=abc", "n_types"),
])
def test_bad_parameter(runner, setting, text):
    result = _run(runner, "run", "--system", "single", "--seeds", "1", "--episodes", "2", "--set", setting)
    assert result.exit_code == 2
    assert text in result.output


def test_bad_algorithm_and_counts(runner):
    result = _run(runner, "run", "--system", "single", "--algorithms", "uniform,mgrao-3:1")
    assert result.exit_code == 2
    assert "algorithms[1]" in result.output and "1, 2, 5, 10" in result.output
    result = _run(runner, "run", "--system", "single", "--episodes", "0")
    assert result.exit_code == 2
    assert "episodes" in result.output


def test_unknown_system(runner):
    result = _run(runner, "run", "--system", "tiny")
    assert result.exit_code == 2


def test_reproduce_json(runner):
    result = _run(runner, "reproduce", "--seeds", "3", "--episodes", "20", "--format", "json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert isinstance(data["systems"]["single"]["mgrao-max"]["pct_from_uniform"], float)
    assert set(data["systems"]) == {"single", "multi", "volatile", "large"}
    assert data["seeds"] == 3 and data["episodes"] == 20


def test_reproduce_table_and_bad_set(runner):
    result = _run(runner, "reproduce", "--seeds", "2", "--episodes", "5")
    assert result.exit_code == 0, result.output
    assert "large" in result.stdout and "mgrao-25:1" in result.stdout
    result = _run(runner, "reproduce", "--seeds", "2", "--episodes", "5", "--set", "trace_decay=1")
    assert result.exit_code == 2
    assert "trace_decay" in result.output


def test_reproduce_defaults_to_100_seeds_and_flags_the_paper_outside_our_interval(runner):
    from mgrao_cli.experiments import reproduce

    seeds = next(p for p in reproduce.params if p.name == "seeds")
    assert seeds.default == 100
    result = _run(runner, "reproduce", "--seeds", "12", "--format", "json")
    data = json.loads(result.stdout)
    assert data["reading"] == "default"
    row = data["systems"]["volatile"]["mgrao-1:1"]
    assert row["paper_outside_ci"] is True  # 3.3 lies far below our interval
    assert row["ci95"][0] > row["paper_pct_from_uniform"]
    assert data["systems"]["single"]["uniform"]["paper_outside_ci"] is None
    assert set(data["max_overtakes_1_1_at"]) == {"single", "multi", "volatile", "large"}
    assert 1 <= data["max_overtakes_1_1_at"]["single"] <= 100
    table = _run(runner, "reproduce", "--seeds", "12")
    assert " 3.3 *" in table.stdout
    assert "mgrao-max stays ahead of mgrao-1:1 from episode" in table.stdout
    assert "paper's figure lies outside our 95% interval" in table.stdout


def test_reproduce_under_a_named_reading_and_set_on_top(runner):
    result = _run(runner, "reproduce", "--seeds", "3", "--episodes", "10", "--reading", "relative-linear",
                  "--set", "learning_rate=0.2", "--format", "json")
    data = json.loads(result.stdout)
    assert data["overrides"] == {"quality_model": "relative-linear", "routing": "per-task", "learning_rate": "0.2"}
    # the first reading: uniform scores exactly 0.3 per parent
    assert data["systems"]["single"]["uniform"]["final_mean"] == pytest.approx(3.0, abs=1e-12)
    bad = _run(runner, "reproduce", "--reading", "nonsense")
    assert bad.exit_code == 2 and "nonsense" in bad.output


@pytest.mark.parametrize("command", [
    ["run", "--system", "single", "--seeds", "1", "--episodes", "3", "--format", "csv"],
    ["reproduce", "--seeds", "2", "--episodes", "3"],
])
def test_out_into_a_missing_directory_is_a_usage_error_before_any_simulation(runner, tmp_path, command):
    missing = tmp_path / "missing" / "dir"
    result = _run(runner, *command, "--out", str(missing / "x.csv"))
    assert result.exit_code == 2, result.output
    assert "--out" in result.output and str(missing) in result.output and "does not exist" in result.output
    assert "simulation" not in result.output  # the table footer / json never got that far
    assert not missing.exists()


def test_out_naming_a_directory_is_refused(runner, tmp_path):
    result = _run(runner, "run", "--system", "single", "--seeds", "1", "--episodes", "3", "--out", str(tmp_path))
    assert result.exit_code == 2
    assert "--out" in result.output


def test_empty_algorithms_is_an_error_not_the_defaults(runner):
    for value in ["", "  "]:
        result = _run(runner, "run", "--system", "single", "--seeds", "1", "--episodes", "3", "--algorithms", value)
        assert result.exit_code == 2, result.output
        assert "--algorithms" in result.output and "is empty" in result.output
    result = _run(runner, "run", "--system", "single", "--seeds", "1", "--episodes", "3", "--algorithms", "uniform,")
    assert result.exit_code == 2
    assert "algorithms[1]" in result.output


def test_serve_on_a_busy_port_says_so_and_starts_nothing(runner, tmp_path):
    import socket

    database = tmp_path / "never.db"
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = runner.invoke(cli, ["serve", "--host", "127.0.0.1", "--port", str(port), "--workers", "2",
                                     "--database-url", f"sqlite:///{database}"])
    assert result.exit_code == 1, result.output
    assert f"port {port} on 127.0.0.1 is in use" in result.output
    assert "http://" not in result.output
    assert not database.exists()


def test_first_seed_runs_the_calibration_seeds(runner):
    result = _run(runner, "run", "--system", "single", "--seeds", "2", "--first-seed", "10000", "--episodes", "3",
                  "--format", "json")
    data = json.loads(result.stdout)
    assert data["spec"]["seeds"] == [10000, 10001]
    table = _run(runner, "reproduce", "--seeds", "2", "--first-seed", "10000", "--episodes", "3", "--format", "json")
    assert json.loads(table.stdout)["first_seed"] == 10000
    too_far = _run(runner, "run", "--system", "single", "--seeds", "3", "--first-seed", str(2**32 - 2))
    assert too_far.exit_code == 2 and "--first-seed" in too_far.output


def test_out_to_a_device_that_refuses_writes_is_a_clean_error(runner):
    import pathlib

    if not pathlib.Path("/dev/full").exists():
        pytest.skip("no /dev/full here")
    result = runner.invoke(cli, ["run", "--system", "single", "--seeds", "1", "--episodes", "2", "--out", "/dev/full"])
    assert result.exit_code != 0
    assert "/dev/full" in result.output and "Traceback" not in result.output
    assert not isinstance(result.exception, OSError)


def test_algorithms_json_is_the_registry_for_the_system(runner):
    from mgrao_core.algorithms import registry
    from mgrao_core.presets import PRESETS

    result = _run(runner, "algorithms", "--system", "large", "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)["data"]
    assert data == registry(PRESETS["large"].params)
    mgrao = next(entry for entry in data if entry["name"] == "mgrao")
    assert mgrao["parameters"] == ["learning_rate", "trace_decay", "temperature", "group_blend"]
    assert mgrao["memory_per_child"]["mgrao-max"] > mgrao["memory_per_child"]["mgrao-1:1"] > 0


def test_algorithms_without_a_system_lists_the_grammar(runner):
    result = _run(runner, "algorithms")
    assert result.exit_code == 0, result.output
    assert "mgrao-{x}:1" in result.stdout and "oracle" in result.stdout and "B per child" not in result.stdout


def test_algorithms_describes_one_label(runner):
    result = _run(runner, "algorithms", "--system", "single", "--label", " MGRAO-05:1", "--json")
    assert result.exit_code == 0, result.output
    described = json.loads(result.stdout)
    assert described["label"] == "mgrao-5:1" and described["groups"] == 5
    assert described["memory_per_child"] == 8 * (2 * 5 * 20 + 6 * 5 + 2) + 1 + 8 * 5  # PW, trace, rows; flag, scratch
    result = _run(runner, "algorithms", "--system", "single", "--label", "mgrao-3:1")
    assert result.exit_code == 2 and "1, 2, 5, 10" in result.output
    text = _run(runner, "algorithms", "--system", "single", "--label", "uniform").stdout
    assert text.startswith("uniform: Uniform (uniform)") and "memory per child: 160 B" in text


def test_help_and_the_web_layers_imports_load_no_numba():
    # `mgrao --help` (and validating a request) needs the schema, not the compiled engine
    for code in ("import mgrao_cli.main", "import mgrao_core; mgrao_core.make_spec('single')"):
        out = subprocess.run([sys.executable, "-c", f"{code}; import sys; print('numba' in sys.modules)"],
                             capture_output=True, text=True, check=True)
        assert out.stdout.strip() == "False", code
    help_text = subprocess.run([sys.executable, "-m", "mgrao_cli", "--help"], capture_output=True, text=True,
                               check=True)
    assert "reproduce" in help_text.stdout
    out = subprocess.run([sys.executable, "-c", "import mgrao_core; print(mgrao_core.run_experiment.__module__)"],
                         capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "mgrao_core.runner"  # the engine still comes with the package, on first use


def test_a_simulating_command_imports_only_its_own_module():
    # subcommands load on first use: `mgrao reproduce` imports neither the service's nor the studies' commands
    code = ("import sys; from mgrao_cli.main import cli; "
            "cli(['reproduce', '--seeds', '1', '--episodes', '2', '--format', 'json'], standalone_mode=False); "
            "print(sorted(m for m in sys.modules if m.startswith('mgrao_cli')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == str(["mgrao_cli", "mgrao_cli.engine_loading",
                                                        "mgrao_cli.experiments", "mgrao_cli.main"])


def test_the_engine_is_imported_with_the_collector_paused_then_frozen():
    code = ("import gc, sys; from mgrao_cli.engine_loading import load_engine; load_engine(); "
            "frozen = gc.get_freeze_count(); load_engine(); "
            "print(gc.isenabled(), 'numba' in sys.modules, frozen > 10_000, gc.get_freeze_count() == frozen)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "True", "True", "True"]  # the second call changes nothing
