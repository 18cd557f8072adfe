"""Experiment specifications: validation with clear errors, limits and the dict round trip."""

import pytest

from mgrao_core import (
    MAX_CHUNK_BYTES,
    MAX_GROUP_UPDATES,
    MAX_RESULT_BYTES,
    MAX_WORK,
    ConfigError,
    WorkLimitError,
    make_spec,
    spec_from_dict,
)
from mgrao_core.budget import chunk_cost, plan_chunks, result_bytes, stored_weights


def _error(**kwargs):
    kwargs.setdefault("system", "single")
    with pytest.raises(ConfigError) as info:
        make_spec(**kwargs)
    return info.value


def test_defaults_from_the_preset():
    spec = make_spec("large")
    assert spec.algorithms[0] == "uniform" and len(spec.algorithms) == 7
    assert spec.seeds == tuple(range(30))
    assert spec.episodes == 100
    assert spec.work == 30 * 7 * 100 * 50 * 5


def test_unknown_system():
    error = _error(system="tiny")
    assert error.field == "system"
    assert "single" in error.message


def test_unknown_algorithm():
    error = _error(algorithms=["uniform", "greedy"])
    assert error.field == "algorithms[1]"
    assert "greedy" in error.message


def test_repeated_algorithm():
    error = _error(algorithms=["uniform", "mgrao-max", "uniform"])
    assert error.field == "algorithms[2]"
    assert "repeat" in error.message


def test_no_algorithm():
    assert _error(algorithms=[]).field == "algorithms"


def test_too_many_algorithms():
    labels = [f"mgrao-{d}:1" for d in range(1, 721) if 720 % d == 0][:21]
    assert len(labels) == 21
    error = _error(algorithms=labels, overrides={"n_parents": 720})
    assert error.field == "algorithms"
    assert "at most 20" in error.message


@pytest.mark.parametrize("seeds", [0, -3, 1001])
def test_bad_seed_count(seeds):
    error = _error(seeds=seeds)
    assert error.field == "seeds"
    assert "1000" in error.message


@pytest.mark.parametrize("episodes", [0, -1, 100_001])
def test_bad_episodes(episodes):
    error = _error(episodes=episodes)
    assert error.field == "episodes"
    assert "between 1 and 100000" in error.message


@pytest.mark.parametrize("episodes", [2.0, "10", True, None])
def test_episodes_wrong_type(episodes):
    error = _error(episodes=episodes)
    assert error.field == "episodes"
    assert "whole number" in error.message


def test_duplicate_seeds():
    error = _error(seeds=[1, 2, 1])
    assert error.field == "seeds"
    assert "repeat" in error.message


@pytest.mark.parametrize(("seeds", "field"), [([0, -1], "seeds[1]"), ([2**32], "seeds[0]"), ([1, "a"], "seeds[1]")])
def test_bad_seed_values(seeds, field):
    error = _error(seeds=seeds)
    assert error.field == field
    assert "[0, 4294967295]" in error.message


def test_seeds_wrong_type():
    assert _error(seeds="1,2").field == "seeds"
    assert _error(seeds=[]).field == "seeds"


def test_x_must_divide_the_parents():
    error = _error(algorithms=["uniform", "mgrao-3:1"])
    assert error.field == "algorithms[1]"
    assert "valid: 1, 2, 5, 10" in error.message


def test_x_to_y_other_than_one():
    # issue 45: y children sharing one model, y dividing n_children (single has one child)
    error = _error(algorithms=["mgrao-2:3"])
    assert error.field == "algorithms[0]"
    assert "y must be a divisor of n_children = 1 (valid: 1)" in error.message


def test_preset_algorithms_checked_against_overridden_parents():
    # the large preset's 25:1 does not divide 40 parents: given, it is refused naming its place and the valid x
    preset = make_spec("large").algorithms
    error = _error(system="large", algorithms=list(preset), overrides={"n_parents": 40})
    assert error.field == "algorithms[5]"
    assert "valid: 1, 2, 4, 5, 8, 10, 20, 40" in error.message
    # left to the preset, its labels valid with 40 parents are taken (issue 43, item 3: a saved large30's defaults)
    assert make_spec("large", overrides={"n_parents": 40}).algorithms == tuple(a for a in preset if a != "mgrao-25:1")


@pytest.mark.parametrize(("name", "value", "limit"), [
    ("n_parents", 0, "[1, 1000000]"), ("trace_decay", 1.0, "0.999"), ("learning_rate", -0.1, "[0, 1]"),
    ("n_types", "abc", "must be a number"), ("bogus", 1, "unknown parameter"),
])
def test_bad_parameters(name, value, limit):
    error = _error(overrides={name: value})
    assert error.field == name
    assert limit in error.message


def test_types_per_composite_over_n_types():
    error = _error(overrides={"n_types": 3})
    assert error.field == "types_per_composite"
    assert "n_types = 3" in error.message


def test_work_limit():
    with pytest.raises(WorkLimitError) as info:
        make_spec("large", seeds=1000, episodes=100_000)
    assert info.value.field == "work"
    assert f"{MAX_WORK:,}" in info.value.message
    assert isinstance(info.value, ConfigError)


def test_group_update_limit():
    # work 100 x 100 x 1000 x 5 = 5e7 is fine, but x 1000 groups = 5e10 row updates > 4e10
    with pytest.raises(WorkLimitError) as info:
        make_spec("single", ["mgrao-max"], seeds=100, episodes=100, overrides={"n_parents": 1000})
    assert info.value.field == "work"
    assert f"{MAX_GROUP_UPDATES:,}" in info.value.message
    spec = make_spec("single", ["uniform", "mgrao-1:1"], seeds=100, episodes=100, overrides={"n_parents": 1000})
    assert spec.group_updates == 100 * 100 * 1000 * 5 * 1


def test_work_at_the_limit_is_accepted():
    # 1000 seeds x 1 algorithm x 400 episodes x 1000 parents x 5 = 2e9 = MAX_WORK exactly
    spec = make_spec("single", ["uniform"], seeds=1000, episodes=400, overrides={"n_parents": 1000})
    assert spec.work == MAX_WORK


def test_memory_limit_names_the_budget_per_chunk():
    overrides = {"n_parents": 1000, "n_types": 200, "n_children": 100}
    # one seed of mgrao-max: Y and F alone are 2 * 100 * 1000 * 200 * 8 B = 320 MB per lane
    with pytest.raises(WorkLimitError) as info:
        make_spec("single", ["mgrao-max"] + [f"mgrao-{g}:1" for g in (1, 2, 4, 5, 8, 10)], seeds=1, episodes=1,
                  overrides=overrides)
    assert info.value.field == "memory"
    assert f"budget of {MAX_CHUNK_BYTES / 1024**2:,.0f} MiB per chunk" in info.value.message
    # many seeds of one are fine: the chunks hold fewer seeds
    overrides["n_children"] = 10
    spec = make_spec("single", ["mgrao-max"], seeds=50, episodes=1, overrides=overrides)
    assert all(chunk_cost(spec, len(c)).total <= MAX_CHUNK_BYTES for c in plan_chunks(spec))
    assert len(plan_chunks(spec)) > 1
    # a smaller budget refuses it
    with pytest.raises(WorkLimitError) as info:
        make_spec("single", ["mgrao-max"], seeds=50, episodes=1, overrides=overrides, memory_budget=50 * 1024**2)
    assert "budget of 50 MiB per chunk" in info.value.message


def test_stored_results_limit():
    # 1000 seeds x 20 algorithms x 100,000 episodes x 8 B = 16 GB of utilities: refused, naming the limit
    algorithms = ["uniform", "oracle", "mgrao-max"] + [f"mgrao-{g}:1" for g in (1, 2, 4, 5, 8, 10, 20, 25, 40, 50)]
    with pytest.raises(WorkLimitError) as info:
        make_spec("single", algorithms[:3], seeds=1000, episodes=100_000, overrides={"n_parents": 1})
    assert info.value.field == "results"
    assert f"{MAX_RESULT_BYTES // 1024**2:,} MiB per experiment" in info.value.message
    assert result_bytes(make_spec("single", ["uniform"], seeds=10, episodes=100)) == 8 * 10 * (100 + 20)


def test_stored_weights_are_bounded_per_run_and_counted():
    # a system of at most 100 children keeps every weight, as before the bounds (and no means)
    small = stored_weights(100, 50, 20)
    assert (small.combined_children, small.group_children, small.means, small.values) == (100, 100, False,
                                                                                        100 * 51 * 20)
    # 10,000 children x 100 groups x 20 types: every child's combined weights, the first 1,000 children's PW
    # (2,000,000 values, 16 MB, not 160 MB) and their means over every child
    large = stored_weights(10_000, 100, 20)
    assert (large.combined_children, large.group_children, large.means, large.group_mean) == (10_000, 1_000, True,
                                                                                            True)
    assert large.values == 10_000 * 20 + 2_000_000 + 20 + 100 * 20
    # one child's PW over the bound: none stored, nor their mean; 200,000 children of 20 types: the first 100,000
    huge = stored_weights(10, 200_000, 20)
    assert (huge.group_children, huge.group_mean) == (0, False)
    assert stored_weights(200_000, 0, 20).combined_children == 100_000
    # the stored results a job may hold count what is stored: 20 seeds of 10,000 children under mgrao-100:1 fit
    # the 2 GiB (they would take 3.3 GB with every child's PW)
    params = {"n_children": 10_000, "n_parents": 20_000, "topology": "ring", "children_per_parent": 4}
    spec = make_spec("multi", ["uniform", "mgrao-100:1"], seeds=20, episodes=100, overrides=params)
    assert result_bytes(spec) == 8 * 20 * (2 * 100 + 10_000 * 20 + 20 + large.values) < MAX_RESULT_BYTES


@pytest.mark.parametrize(("labels", "expected"), [
    ([" MGRAO-05:1", "Uniform", "mgrao-max"], ("mgrao-5:1", "uniform", "mgrao-max")),
    (["mgrao-0010:1"], ("mgrao-10:1",)),
])
def test_labels_are_read_in_their_canonical_spelling(labels, expected):
    assert make_spec("single", labels, seeds=1, episodes=1).algorithms == expected


def test_twenty_spellings_of_one_algorithm_are_a_repeat():
    labels = ["mgrao-1:1"] + ["mgrao-" + "0" * i + "1:1" for i in range(1, 20)]
    with pytest.raises(ConfigError) as info:
        make_spec("single", labels, seeds=1, episodes=1)
    assert info.value.field == "algorithms[1]"
    assert "repeats algorithms[0]" in info.value.message


@pytest.mark.parametrize("kwargs", [
    {"system": "single"},
    {"system": "large", "algorithms": ["uniform", "oracle", "mgrao-25:1"], "seeds": [9, 3, 4], "episodes": 7},
    {"system": "volatile", "seeds": 4, "overrides": {"rejoin_profile": "new", "temperature": 1.0}},
    {"system": "multi", "overrides": {"tie_break": "first", "initial_estimate": 0.0, "n_types": 30}},
])
def test_dict_round_trip(kwargs):
    spec = make_spec(**kwargs)
    again = spec_from_dict(spec.as_dict())
    assert again == spec
    assert again.as_dict() == spec.as_dict()


def test_dict_round_trip_through_json():
    import json

    spec = make_spec("multi", ["uniform", "mgrao-2:1"], seeds=[5, 1], episodes=3, overrides={"epsilon": 0.2})
    assert spec_from_dict(json.loads(json.dumps(spec.as_dict()))) == spec


def test_spec_from_dict_revalidates():
    data = make_spec("single", seeds=2, episodes=3).as_dict()
    data["params"]["n_parents"] = 0
    with pytest.raises(ConfigError) as info:
        spec_from_dict(data)
    assert info.value.field == "n_parents"
