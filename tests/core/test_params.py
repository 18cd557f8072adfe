"""The parameter schema, validation and the presets."""

import dataclasses
import math

import pytest

from mgrao_core import PAPER_SYSTEMS, PARAMETERS, PRESETS, ConfigError, SystemParams, get_preset, make_params


def test_schema_defaults_match_the_dataclass():
    defaults = SystemParams()
    assert [p.name for p in PARAMETERS] == [f.name for f in dataclasses.fields(SystemParams)]
    for p in PARAMETERS:
        assert getattr(defaults, p.name) == p.default, p.name
    plain = defaults.as_dict()
    assert plain["composite_periods"] == [] and plain["schedule"] == []  # lists as JSON lists


def test_simulation_md_defaults():
    p = SystemParams()
    assert (p.n_types, p.n_composite_types, p.types_per_composite) == (20, 10, 5)
    assert (p.learning_rate, p.trace_decay, p.value_noise, p.quality_at_uniform) == (0.1, 0.9, 0.1, 0.3)
    assert p.effective_temperature == pytest.approx(1 / 20)
    assert make_params({"temperature": 1}).effective_temperature == 1.0
    assert make_params({"n_types": 8}).effective_temperature == pytest.approx(1 / 8)


def test_schema_entries_are_json_ready():
    for p in PARAMETERS:
        data = p.as_dict()
        assert data["name"] == p.name
        assert isinstance(data["choices"], list)


def test_strings_are_coerced():
    params = make_params({"n_parents": "12", "learning_rate": "0.25", "tie_break": "first"})
    assert params.n_parents == 12 and isinstance(params.n_parents, int)
    assert params.learning_rate == 0.25
    assert params.tie_break == "first"


def test_whole_float_is_accepted_for_an_int():
    assert make_params({"n_parents": 12.0}).n_parents == 12


@pytest.mark.parametrize(("name", "value", "limit"), [
    ("n_parents", 0, "[1, 1000000]"),
    ("n_parents", 1_000_001, "[1, 1000000]"),
    ("trace_decay", 1.0, "[0.001, 0.999]"),
    ("trace_decay", 0.0, "[0.001, 0.999]"),
    ("learning_rate", -0.1, "[0, 1]"),
    ("temperature", 0.0, "[0.0001, 100]"),
    ("temperature", 1e-310, "[0.0001, 100]"),
    ("temperature", 5e-324, "[0.0001, 100]"),
    ("temperature", "1e-320", "[0.0001, 100]"),
    ("boltzmann_temperature", 1e-300, "[0.0001, 100]"),
    ("quality_at_uniform", 0.0, "[0.001, 1]"),
    ("half_saturation", 0.0, "[0.001, 10]"),
    ("half_saturation", 11, "[0.001, 10]"),
    ("absent_quality", 1.5, "[0, 1]"),
    ("absent_quality", -0.1, "[0, 1]"),
    ("resource_mean", 1e-9, "[0.001, 1]"),
    ("epsilon", 1.5, "[0, 1]"),
    ("n_types", 1, "[2, 200]"),
])
def test_out_of_range(name, value, limit):
    with pytest.raises(ConfigError) as info:
        make_params({name: value})
    assert info.value.field == name
    assert limit in info.value.message
    assert str(info.value).startswith(f"{name}: ")


@pytest.mark.parametrize(("name", "value", "text"), [
    ("n_types", "abc", "must be a number"),
    ("learning_rate", "abc", "must be a number"),
    ("n_types", 2.5, "whole number"),
    ("n_types", True, "must be a number"),
    ("n_types", [3], "must be a number"),
    ("learning_rate", math.nan, "finite"),
    ("learning_rate", "inf", "finite"),
    ("tie_break", "last", "random, first"),
    ("quality_model", "linear", "hyperbolic, exponential, relative-linear"),
    ("routing", "per-child", "per-composite, per-task"),
    ("absent_tasks", "ignored", "excluded, counted"),
    ("load_sharing", "maybe", "true or false"),
    ("load_sharing", 2, "true or false"),
    ("load_sharing", None, "must not be empty"),
    ("rejoin_profile", None, "must not be empty"),
    ("n_parents", None, "must not be empty"),
])
def test_wrong_type(name, value, text):
    with pytest.raises(ConfigError) as info:
        make_params({name: value})
    assert info.value.field == name
    assert text in info.value.message


def test_nullable_temperature():
    assert make_params({"temperature": None}).temperature is None


def test_unknown_parameter():
    with pytest.raises(ConfigError) as info:
        make_params({"n_parent": 3})
    assert info.value.field == "n_parent"
    assert "unknown parameter" in info.value.message


def test_types_per_composite_at_most_n_types():
    with pytest.raises(ConfigError) as info:
        make_params({"n_types": 4, "types_per_composite": 5})
    assert info.value.field == "types_per_composite"
    assert "n_types = 4" in info.value.message
    assert make_params({"n_types": 5, "types_per_composite": 5}).types_per_composite == 5


def test_overrides_apply_on_the_base():
    base = get_preset("volatile").params
    params = make_params({"n_parents": 20}, base=base)
    assert params.leave_probability == 0.25 and params.n_parents == 20


def test_presets_match_the_paper():
    assert PAPER_SYSTEMS == ("single", "multi", "volatile", "large")
    assert set(PRESETS) == {*PAPER_SYSTEMS, "drift", "bursty", "multi-resource", "cloud", "edge"}
    assert all(PRESETS[name].paper_pct_from_uniform for name in PAPER_SYSTEMS)
    assert (PRESETS["single"].params.n_parents, PRESETS["single"].params.n_children) == (10, 1)
    assert PRESETS["multi"].params.n_children == 3
    assert PRESETS["volatile"].params.leave_probability == 0.25
    assert PRESETS["volatile"].params.join_probability == 0.25
    assert PRESETS["large"].params.n_parents == 50
    assert PRESETS["large"].algorithms == (
        "uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-25:1", "mgrao-max")
    assert PRESETS["single"].paper_pct_from_uniform == {"mgrao-max": 28.0, "mgrao-1:1": 23.4}


def test_unknown_preset():
    with pytest.raises(ConfigError) as info:
        get_preset("huge")
    assert info.value.field == "system"
    assert "single, multi, volatile, large" in info.value.message


def test_empty_temperature_means_the_automatic_value():
    params = make_params({"temperature": ""})
    assert params.temperature is None
    assert params.effective_temperature == pytest.approx(1 / params.n_types)


def test_integer_parameter_accepts_whole_numbers_written_as_floats():
    assert make_params({"n_parents": "1e2"}).n_parents == 100
    with pytest.raises(ConfigError) as error:
        make_params({"n_parents": "10.5"})
    assert error.value.field == "n_parents"
    assert "whole number" in error.value.message


def test_new_environment_defaults():
    p = SystemParams()
    assert (p.quality_model, p.routing, p.load_sharing, p.absent_tasks) == (
        "hyperbolic", "per-composite", False, "excluded")
    assert p.absent_quality is None


@pytest.mark.parametrize(("value", "expected"), [(True, True), ("on", True), ("true", True), ("1", True), (1, True),
                                                 (False, False), ("off", False), ("False", False), (0, False)])
def test_load_sharing_accepts_booleans_in_their_usual_spellings(value, expected):
    assert make_params({"load_sharing": value}).load_sharing is expected


def test_every_float_has_finite_documented_bounds():
    for p in PARAMETERS:
        if p.kind == "float":
            assert p.minimum is not None and math.isfinite(p.minimum), p.name
            assert p.maximum is not None and math.isfinite(p.maximum), p.name
            assert p.minimum >= 0, p.name


@pytest.mark.parametrize("name", [p.name for p in PARAMETERS if p.kind == "float"])
def test_a_number_of_hundreds_of_digits_is_refused_naming_the_field(name):
    with pytest.raises(ConfigError) as info:
        make_params({name: 10**400})
    assert info.value.field == name and "finite" in info.value.message


def test_negative_zero_is_zero():
    params = make_params({"resource_sd": -0.0, "value_noise": "-0.0"})
    assert math.copysign(1.0, params.resource_sd) == 1.0
    assert math.copysign(1.0, params.value_noise) == 1.0
    from mgrao_core import make_spec, run_experiment

    run_experiment(make_spec("single", seeds=1, episodes=2, overrides={"resource_sd": -0.0}))  # numpy refused -0.0


def test_a_huge_integer_for_an_int_parameter_names_the_limit():
    with pytest.raises(ConfigError) as info:
        make_params({"n_parents": 10**400})
    assert "[1, 1000000]" in info.value.message and "too large" in info.value.message


@pytest.mark.parametrize("text", ["1_0", "\u0663", "\uff13", "1\u00a0", "0x10", "1,5", "nan", "-Infinity", "", "+"])
def test_a_number_as_text_is_plain_decimal_or_exponent_notation_only(text):
    # float() read "1_0" as 10 and the Arabic-Indic "٣" as 3 (issue 47, item 9)
    for name in ("task_need", "n_parents"):
        with pytest.raises(ConfigError) as info:
            make_params({name: text})
        assert info.value.field == name
        assert repr(text) in info.value.message or "finite" in info.value.message


@pytest.mark.parametrize(("text", "value"), [
    ("3", 3.0), ("+3", 3.0), ("-0", 0.0), ("0.5", 0.5), (".5", 0.5), ("5.", 5.0), ("1e0", 1.0),
    ("2.5E-1", 0.25), (" 4 ", 4.0), ("1e+1", 10.0),
])
def test_plain_decimal_and_exponent_text_is_still_a_number(text, value):
    assert make_params({"task_need": text}).task_need == value


def test_text_numbers_in_lists_and_events_follow_the_same_rule():
    with pytest.raises(ConfigError) as info:
        make_params({"frequency_profile": "explicit", "n_composite_types": 2, "composite_periods": "1,1_0"})
    assert info.value.field == "composite_periods[1]"
    assert make_params({"frequency_profile": "explicit", "n_composite_types": 2,
                        "composite_periods": "1, 10"}).composite_periods == (1, 10)
