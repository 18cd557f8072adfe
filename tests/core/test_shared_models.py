"""Children that share their model, ``mgrao-x:y`` (issue 45): docs/algorithms.md, "Children that share their model".

The label grammar and its errors; the engine against the dense reference (1e-12) with teams of several children,
under several resources, volatility, load sharing, tasks that fail, a learning cost and sparse worlds (a ring and
random links, each parent linked to fewer children than there are); a team's members allocate
alike and show one PW; what a child learns and keeps is the team's divided by y; ``mgrao-x:1`` is today's (the
golden runs, tests/core/test_golden.py, hold it bit for bit).
"""

import json

import numpy as np
import pytest

from mgrao_core import ConfigError, make_params, make_spec, run_experiment
from mgrao_core.algorithms import FAMILIES_BY_NAME, describe_label, parse_algorithm, registry, sort_key, task_share
from mgrao_core.algorithms.mgrao import teams

from ._helpers import assert_matches_reference, assert_resources_match_reference

MGRAO = FAMILIES_BY_NAME["mgrao"]
SIX = {"n_children": 6}  # teams of 1, 2, 3 and 6


def test_labels_and_their_errors():
    algorithm = parse_algorithm(" MGRAO-05:02 ", 10, n_children=6)
    assert (algorithm.label, algorithm.n_groups, algorithm.team_size) == ("mgrao-5:2", 5, 2)
    assert parse_algorithm("mgrao-5:1", 10, n_children=6).team_size == 1
    assert parse_algorithm("mgrao-5:4", None).team_size == 4  # the grammar alone: any whole y of at least 1
    with pytest.raises(ConfigError) as error:
        parse_algorithm("mgrao-5:2", 10, "algorithms[1]", n_children=3)
    assert error.value.field == "algorithms[1]"
    assert "y must be a divisor of n_children = 3 (valid: 1, 3)" in error.value.message
    with pytest.raises(ConfigError, match="y must be a whole number of at least 1"):
        parse_algorithm("mgrao-5:0", 10)
    with pytest.raises(ConfigError, match="x must be a divisor of n_parents = 10"):
        parse_algorithm("mgrao-3:3", 10, n_children=3)
    with pytest.raises(ConfigError) as error:  # what make_spec says, by field
        make_spec("multi", ["uniform", "mgrao-5:2"], seeds=1, episodes=2)
    assert any(e.field == "algorithms[1]" and "(valid: 1, 3)" in e.message
               for e in getattr(error.value, "errors", (error.value,)))
    assert make_spec("multi", ["uniform", "mgrao-5:3"], seeds=1, episodes=2).algorithms == ("uniform", "mgrao-5:3")


def test_the_registry_gives_the_valid_y_and_the_memory_of_a_child():
    params = make_params({"n_parents": 10, "n_children": 6})
    forms = next(f for f in registry(params) if f["name"] == "mgrao")["forms"]
    shared = next(form for form in forms if form["template"] == "mgrao-{x}:{y}")
    assert shared["valid"] == [1, 2, 5, 10] and shared["second_argument"] == "y"
    assert shared["second_valid"] == [2, 3, 6]
    assert next(f for f in registry(None) if f["name"] == "mgrao")["forms"][1]["second_valid"] is None
    one, two = describe_label("mgrao-5:1", params), describe_label("mgrao-5:2", params)
    assert (one["team_size"], two["team_size"], describe_label("uniform", params)["team_size"]) == (1, 2, None)
    assert two["memory_per_child"] == -(-one["memory_per_child"] // 2)  # a team's bytes over y, rounded up
    assert sort_key("mgrao-5:1") < sort_key("mgrao-10:1") < sort_key("mgrao-1:2") < sort_key("mgrao-5:2") \
        < sort_key("mgrao-5:3") < sort_key("mgrao-max")


def test_y_at_the_largest_system():
    # n_children up to 1,000,000 (the scale issue's bound): its 48 valid y above 1, listed whole in the error
    params = make_params({"n_children": 1_000_000, "n_parents": 1_000_000})
    shared = next(f for f in registry(params) if f["name"] == "mgrao")["forms"][1]
    assert len(shared["second_valid"]) == 48 and shared["second_valid"][-3:] == [250000, 500000, 1000000]
    assert parse_algorithm("mgrao-1000:1000", 1_000_000, n_children=1_000_000).team_size == 1000
    with pytest.raises(ConfigError) as error:
        parse_algorithm("mgrao-10:3", 1_000_000, n_children=1_000_000)
    assert "y must be a divisor of n_children = 1000000 (valid: 1, 2, 4, 5, 8, 10, 16, " in error.value.message
    assert error.value.message.endswith("500000, 1000000)")


def test_what_a_child_learns_is_the_teams_over_y():
    params = make_params({"n_parents": 10, "n_children": 6, "n_resources": 2, "learning_cost": 0.3})
    one, three = parse_algorithm("mgrao-5:1", 10), parse_algorithm("mgrao-5:3", 10)
    assert MGRAO.learned_numbers(one, params) == 5 * 41 * 2
    assert MGRAO.learned_numbers(three, params) == pytest.approx(5 * 41 * 2 / 3)
    assert 1 - task_share(three, params) == pytest.approx((1 - task_share(one, params)) / 3)


def test_teams_are_consecutive_children():
    assert teams(6, 2).tolist() == [0, 0, 1, 1, 2, 2]
    assert teams(6, 1).tolist() == list(range(6))


SHARED = ["uniform", "mgrao-1:1", "mgrao-1:2", "mgrao-5:3", "mgrao-10:6", "mgrao-max"]
CASES = [
    SIX,
    {**SIX, "leave_probability": 0.25, "join_probability": 0.25, "absent_tasks": "counted"},
    {**SIX, "routing": "per-task", "load_sharing": True, "quality_model": "exponential"},
    {**SIX, "routing": "per-task", "load_sharing": True, "task_need": 1.2, "hierarchy": "borrow"},
    {**SIX, "topology": "ring", "children_per_parent": 2, "routing": "per-task", "load_sharing": True},
    {**SIX, "topology": "random", "children_per_parent": 3, "leave_probability": 0.2, "join_probability": 0.3},
    {**SIX, "learning_cost": 0.2, "group_blend": "dkl-only", "unpredictable_fraction": 0.2},
]


@pytest.mark.parametrize("overrides", CASES, ids=[str(c) for c in CASES])
def test_engine_equals_reference(overrides):
    result = run_experiment(make_spec("multi", SHARED, seeds=[0, 3], episodes=20, overrides=overrides))
    assert_matches_reference(result, atol=1e-12)
    for run in result.runs:
        y = parse_algorithm(run.algorithm, 10).team_size
        for team in range(6 // y):  # a team's members allocate alike and show one PW
            members = slice(team * y, (team + 1) * y)
            assert (run.combined_weights[members] == run.combined_weights[team * y]).all()
            assert (run.group_weights[members] == run.group_weights[team * y]).all()


@pytest.mark.parametrize("overrides", [
    {**SIX, "n_resources": 2, "resource_credit": "by-share"},
    {**SIX, "n_resources": 3, "resource_combination": "weighted", "leave_probability": 0.2, "join_probability": 0.4},
    {**SIX, "n_resources": 2, "routing": "per-task", "load_sharing": True, "task_need": 1.0, "hierarchy": "hand-over"},
    {**SIX, "n_resources": 2, "topology": "ring", "children_per_parent": 2, "learning_cost": 0.2},
    {**SIX, "n_resources": 2, "topology": "random", "children_per_parent": 4, "routing": "per-task",
     "load_sharing": True},
])
def test_engine_equals_reference_with_several_resources(overrides):
    result = run_experiment(make_spec("multi", SHARED, seeds=[1, 4], episodes=20, overrides=overrides))
    assert_resources_match_reference(result, atol=1e-12)
    for run in (r for r in result.runs if r.algorithm == "mgrao-5:3"):
        assert (run.resource_weights[:, :3] == run.resource_weights[:, :1]).all()
        assert (run.resource_group_weights[:, 3:] == run.resource_group_weights[:, 3:4]).all()


def test_a_shared_model_differs_from_its_members_own():
    # the same world, seed and groups: sharing changes what the children learn (and so is not x:1 under a new name)
    result = run_experiment(make_spec("multi", ["mgrao-5:1", "mgrao-5:3"], seeds=[2], episodes=10, overrides=SIX))
    own, shared = result.runs
    assert not np.array_equal(own.group_weights, shared.group_weights)
    assert not np.array_equal(own.group_weights[0], own.group_weights[1])  # each child its own


def test_the_command_line_names_the_valid_y_and_runs_a_shared_configuration():
    from click.testing import CliRunner

    from mgrao_cli.main import cli

    runner = CliRunner()
    listed = runner.invoke(cli, ["algorithms", "--system", "cloud"], catch_exceptions=False)
    assert "mgrao-{x}:{y}: x parent groups per child, one model shared by each team of y children " \
           "(x in 1, 2, 4, 5, 8, 10, 20, 40; y in 2, 4, 8)" in listed.output
    described = runner.invoke(cli, ["algorithms", "--system", "cloud", "--label", "mgrao-5:2"], catch_exceptions=False)
    assert "children sharing one model: 2" in described.output
    refused = runner.invoke(cli, ["run", "--system", "multi", "--algorithms", "uniform,mgrao-5:2"])
    assert refused.exit_code != 0
    assert "algorithms[1]" in refused.output and "y must be a divisor of n_children = 3 (valid: 1, 3)" in refused.output
    ran = runner.invoke(cli, ["run", "--system", "multi", "--algorithms", "uniform,mgrao-5:3", "--seeds", "2",
                              "--episodes", "5", "--format", "json"], catch_exceptions=False)
    assert ran.exit_code == 0, ran.output
    assert set(json.loads(ran.stdout)["summary"]) == {"uniform", "mgrao-5:3"}
