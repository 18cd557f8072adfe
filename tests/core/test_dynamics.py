"""The system's dynamics: task frequencies, scheduled events, unpredictable parents, children's capability.

Each option and their combinations in the engine against the dense reference (1e-12, utilities and final
weights), determinism over chunks and blocks, the per-seed timeline itself, the oracle, and bad input.
"""

import json

import numpy as np
import pytest

from mgrao_core import ConfigError, make_params, make_spec, run_experiment
from mgrao_core.oracle import expected_type_values, oracle_weights
from mgrao_core.parameter import Record
from mgrao_core.params import PARAMETERS_BY_NAME
from mgrao_core.world import NEW_COMPOSITE, NEW_PROFILE, EpisodeStreams, composite_periods, draw_world, is_dynamic

from ._helpers import assert_matches_reference

ALGORITHMS = ["uniform", "oracle", "mgrao-1:1", "mgrao-2:1", "mgrao-max", "mgrao-adaptive:3", "independent-q", "bandit"]
SCHEDULE = [{"episode": 4, "change": "new-profiles", "fraction": 0.3},
            {"episode": 9, "change": "new-composites", "fraction": 0.5},
            {"episode": 12, "change": "frequencies", "fraction": 0.5, "period": 3},
            {"episode": 12, "change": "new-profiles"}]
CASES = {
    "two-speed": ("single", {"frequency_profile": "two-speed", "slow_period": 3}),
    "explicit": ("large", {"frequency_profile": "explicit", "composite_periods": [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]}),
    "schedule": ("single", {"schedule": SCHEDULE}),
    "schedule-multi-per-task": ("multi", {"schedule": SCHEDULE, "routing": "per-task"}),
    "unpredictable": ("single", {"unpredictable_fraction": 0.3}),
    "unpredictable-two-speed": ("large", {"unpredictable_fraction": 0.2, "frequency_profile": "two-speed"}),
    "capability": ("multi", {"capability_spread": 0.8}),
    "capability-exponential": ("multi", {"capability_spread": 0.5, "quality_model": "exponential"}),
    "everything-volatile": ("volatile", {"schedule": SCHEDULE, "unpredictable_fraction": 0.2,
                                         "frequency_profile": "two-speed", "rejoin_profile": "new",
                                         "absent_tasks": "counted", "capability_spread": 0.5}),
    "everything-multi-load": ("multi", {"schedule": SCHEDULE, "unpredictable_fraction": 0.2, "load_sharing": True,
                                        "frequency_profile": "explicit", "capability_spread": 1.0,
                                        "composite_periods": [2, 1, 1, 3, 1, 1, 4, 1, 1, 1]}),
    "relative-linear": ("multi", {"schedule": SCHEDULE, "frequency_profile": "two-speed",
                                  "quality_model": "relative-linear", "capability_spread": 0.5}),
    "drift": ("drift", {"schedule": [{"episode": 10, "change": "new-profiles", "fraction": 0.3}]}),
    "bursty": ("bursty", {}),
}


@pytest.mark.parametrize("name", list(CASES))
def test_engine_equals_reference(name):
    system, overrides = CASES[name]
    spec = make_spec(system, ALGORITHMS, seeds=[0, 5], episodes=20, overrides=overrides)
    assert_matches_reference(run_experiment(spec), atol=1e-12)


def test_bounded_learner_equals_reference_under_dynamics():
    # more than MIN_BOUNDED_GROUPS groups: the bounded lazy update, with rows whose parents go quiet
    overrides = {"n_parents": 80, "types_per_composite": 3, "unpredictable_fraction": 0.25,
                 "frequency_profile": "two-speed", "slow_period": 5, "schedule": SCHEDULE}
    spec = make_spec("single", ["uniform", "mgrao-max"], seeds=[3], episodes=20, overrides=overrides)
    assert_matches_reference(run_experiment(spec))


def _numbers(result):
    return [(r.algorithm, r.seed, r.utilities.tobytes(), r.group_weights.tobytes(), r.combined_weights.tobytes())
            for r in result.runs]


def test_chunks_and_blocks_change_no_number():
    system, overrides = CASES["everything-multi-load"]
    spec = make_spec(system, ALGORITHMS, seeds=[0, 1, 2], episodes=20, overrides=overrides)
    whole = _numbers(run_experiment(spec))
    assert _numbers(run_experiment(spec, episodes_per_block=3)) == whole
    assert _numbers(run_experiment(spec, memory_budget=1)) == whole  # one seed per chunk
    alone = make_spec(system, ALGORITHMS, seeds=[2], episodes=20, overrides=overrides)
    assert _numbers(run_experiment(alone)) == [n for n in whole if n[1] == 2]


def test_defaults_draw_no_dynamics():
    params = make_params()
    assert not is_dynamic(params)
    draws = EpisodeStreams(params, 0).draw(5)
    assert draws.changes.shape == (5, 0) and draws.arrives.shape == (5, 0) and draws.event_profiles.shape == (5, 0, 0)
    np.testing.assert_array_equal(draw_world(params, 0).capability, np.ones((1, 20)))
    assert not is_dynamic(make_params({"frequency_profile": "explicit", "composite_periods": [1] * 10}))


def test_dynamics_leave_the_existing_streams_alone():
    plain = EpisodeStreams(make_params(), 4).draw(30)
    dynamic = EpisodeStreams(make_params(CASES["everything-volatile"][1]), 4).draw(30)
    for name in ("noise", "order"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(dynamic, name))
    base, spread = draw_world(make_params(), 4), draw_world(make_params({"capability_spread": 1.0}), 4)
    np.testing.assert_array_equal(base.profiles, spread.profiles)
    np.testing.assert_array_equal(base.resources, spread.resources)


def test_timeline_does_not_depend_on_the_block_size():
    params = make_params(CASES["everything-volatile"][1])
    whole = EpisodeStreams(params, 9).draw(30)
    streams = EpisodeStreams(params, 9)
    parts = [streams.draw(n) for n in (1, 7, 22)]
    for name in ("changes", "event_profiles", "event_types", "arrives"):
        np.testing.assert_array_equal(getattr(whole, name), np.concatenate([getattr(p, name) for p in parts]))


def test_two_speed_arrivals():
    params = make_params({"frequency_profile": "two-speed", "slow_period": 4, "n_parents": 50})
    np.testing.assert_array_equal(composite_periods(params), [1] * 5 + [4] * 5)
    arrives = EpisodeStreams(params, 1).draw(40).arrives
    composite = np.arange(50) % 10
    assert arrives[:, composite < 5].all()
    slow = arrives[:, composite >= 5]
    assert (slow.sum(axis=0) == 10).all()  # every 4th episode of 40
    for k in range(5, 10):  # one phase per composite type: its parents arrive together
        column = arrives[:, composite == k]
        assert (column == column[:, :1]).all()


def test_explicit_periods_and_a_frequency_event():
    params = make_params({"frequency_profile": "explicit", "composite_periods": [1, 2, 3, 4, 5, 6, 7, 8, 9, 10],
                          "schedule": [{"episode": 60, "change": "frequencies", "fraction": 1.0, "period": 2}]})
    arrives = EpisodeStreams(params, 2).draw(120).arrives
    for k in range(10):
        assert arrives[:60, k].sum() == pytest.approx(60 / (k + 1), abs=1)
        assert arrives[60:, k].sum() == 30


def test_a_schedule_event_changes_exactly_its_share_of_parents_at_its_episode():
    params = make_params({"n_parents": 20, "schedule": [{"episode": 7, "change": "new-profiles", "fraction": 0.3},
                                                        {"episode": 9, "change": "new-composites", "fraction": 0.5}]})
    draws = EpisodeStreams(params, 3).draw(15)
    assert set(np.flatnonzero(draws.changes.any(axis=1))) == {7, 9}
    assert (draws.changes[7] == NEW_PROFILE).sum() == 6 and (draws.changes[7] != 0).sum() == 6
    assert (draws.changes[9] == NEW_COMPOSITE).sum() == 10
    np.testing.assert_allclose(draws.event_profiles[7][draws.changes[7] != 0].sum(axis=1), 1.0)
    world = draw_world(params, 3)
    for row in draws.event_types[9][draws.changes[9] != 0]:
        assert any((row == c).all() for c in world.composite_types)
    # an event's draws are its own: adding another event changes none of them
    more = make_params({"n_parents": 20, "schedule": [*params.schedule, {"episode": 2, "change": "new-profiles"}]})
    again = EpisodeStreams(more, 3).draw(15)
    np.testing.assert_array_equal(again.event_profiles[7], draws.event_profiles[7])


def test_unpredictable_parents_change_every_episode():
    params = make_params({"n_parents": 20, "unpredictable_fraction": 0.25})
    draws = EpisodeStreams(params, 0).draw(10)
    changed = draws.changes == NEW_PROFILE | NEW_COMPOSITE
    assert (changed.sum(axis=1) == 5).all() and (changed == changed[:1]).all()  # the same 5 parents throughout
    assert draws.arrives.all()  # every composite type arrives every episode


def test_capability_is_log_normal_per_child_and_type():
    world = draw_world(make_params({"n_children": 50, "capability_spread": 0.5}), 0)
    assert world.capability.shape == (50, 20)
    assert np.log(world.capability).std() == pytest.approx(0.5, rel=0.1)
    np.testing.assert_array_equal(world.type_resources, world.resources[:, None] / world.capability)


def test_oracle_counts_arrival_rates_and_capability():
    base = make_params()
    slow = make_params({"frequency_profile": "explicit", "composite_periods": [1, 2, 1, 1, 1, 1, 1, 1, 1, 4]})
    world = draw_world(base, 6)
    v_base, v_slow = expected_type_values(base, world, 6), expected_type_values(slow, world, 6)
    rates = 1.0 / composite_periods(slow)[np.arange(10) % 10]
    assert v_slow.sum() == pytest.approx(v_base.sum() - sum(1 - r for r in rates))  # each composite's ctv sums to 1
    capable = make_params({"capability_spread": 1.0, "n_children": 2})
    weights = oracle_weights(capable, draw_world(capable, 6), 6)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    assert not np.allclose(weights[0], weights[1])


def test_oracle_counts_unpredictable_parents_in_expectation():
    params = make_params({"unpredictable_fraction": 1.0})
    world = draw_world(params, 0)
    values = expected_type_values(params, world, 0)
    expected = np.zeros(20)
    np.add.at(expected, world.composite_types.ravel(), 10 / 50)  # 10 parents, each composite at 1/10, 1/5 per type
    np.testing.assert_allclose(values, expected, rtol=1e-12)


def test_schema_describes_the_new_kinds():
    periods = PARAMETERS_BY_NAME["composite_periods"].as_dict()
    assert (periods["kind"], periods["item_kind"], periods["minimum"], periods["maximum"]) == ("list", "int", 1, 1000)
    assert (periods["default"], periods["min_items"], periods["max_items"]) == ([], 0, 1000)
    schedule = PARAMETERS_BY_NAME["schedule"].as_dict()
    assert schedule["kind"] == "events" and schedule["default"] == []
    fields = {f["name"]: f for f in schedule["fields"]}
    assert list(fields) == ["episode", "change", "fraction", "period"]
    assert fields["change"]["choices"] == ["new-profiles", "new-composites", "frequencies"]
    assert (fields["fraction"]["minimum"], fields["fraction"]["maximum"]) == (0.0, 1.0)
    assert fields["episode"]["maximum"] == 99_999
    assert "item_kind" not in PARAMETERS_BY_NAME["n_types"].as_dict()
    json.dumps([PARAMETERS_BY_NAME[n].as_dict() for n in PARAMETERS_BY_NAME])


def test_values_are_immutable_and_given_back_as_plain_json():
    params = make_params({"composite_periods": "1, 2,4", "schedule": json.dumps(SCHEDULE[:2])})
    assert params.composite_periods == (1, 2, 4)
    assert isinstance(params.schedule[0], Record) and params.schedule[1].change == "new-composites"
    plain = params.as_dict()
    assert plain["composite_periods"] == [1, 2, 4]
    assert plain["schedule"][0] == {"episode": 4, "change": "new-profiles", "fraction": 0.3, "period": 1}
    assert make_params(plain) == params  # round trip
    assert make_params({"n_types": 30}, base=params).schedule == params.schedule
    assert make_params({"composite_periods": "[3, 5]"}).composite_periods == (3, 5)
    assert make_params({"composite_periods": ""}).composite_periods == ()
    hash(params)


@pytest.mark.parametrize(("overrides", "field", "message"), [
    ({"schedule": [SCHEDULE[0], SCHEDULE[1], {"episode": 2, "change": "new-profiles", "fraction": 1.5}]},
     "schedule[2].fraction", "must be in [0, 1] (got 1.5)"),
    ({"schedule": [{"episode": 100_000, "change": "new-profiles"}]}, "schedule[0].episode", "[0, 99999]"),
    ({"schedule": [{"episode": 3, "change": "frequencies", "period": 0}]}, "schedule[0].period", "[1, 1000]"),
    ({"schedule": [{"episode": 3}]}, "schedule[0].change", "is required"),
    ({"schedule": [{"change": "new-profiles"}]}, "schedule[0].episode", "is required"),
    ({"schedule": [{"episode": 3, "change": "new-values"}]}, "schedule[0].change", "must be one of"),
    ({"schedule": [{"episode": 3, "change": "new-profiles", "when": 2}]}, "schedule[0].when", "unknown field"),
    ({"schedule": [3]}, "schedule[0]", "must be an object"),
    ({"schedule": "[{"}, "schedule", "must be a JSON list"),
    ({"schedule": 5}, "schedule", "must be a list"),
    ({"schedule": [{"episode": 1, "change": "new-profiles"}] * 101}, "schedule", "at most 100 items"),
    ({"composite_periods": [1, 2, 3, 0]}, "composite_periods[3]", "must be in [1, 1000] (got 0)"),
    ({"composite_periods": "1,x"}, "composite_periods[1]", "must be a number"),
    ({"composite_periods": [2.5]}, "composite_periods[0]", "whole number"),
    ({"frequency_profile": "explicit", "composite_periods": [1, 2]}, "composite_periods", "n_composite_types = 10"),
    ({"frequency_profile": "sometimes"}, "frequency_profile", "must be one of"),
    ({"slow_period": 0}, "slow_period", "[1, 1000]"),
    ({"unpredictable_fraction": 1.2}, "unpredictable_fraction", "[0, 1]"),
    ({"capability_spread": -0.1}, "capability_spread", "[0, 3]"),
])
def test_bad_input_names_the_field_and_the_limit(overrides, field, message):
    with pytest.raises(ConfigError) as info:
        make_params(overrides)
    assert info.value.field == field
    assert message in info.value.message
