"""A configuration's identity survives new parameters: stored ``params`` and ``config_hash`` (docs/model.md).

Parameters added since issue 20 declare ``identity="when-set"``: a configuration names them only when they
differ from their default, so the hash of every existing configuration stays what it was and old and new
jobs of one configuration still pool in compare.
"""

from __future__ import annotations

import importlib
import json
from contextlib import nullcontext
from pathlib import Path

import pytest

from backend.store.crud import config_hash, job_dict
from mgrao_core import PARAMETERS, PRESETS, complete_params, identity_params, make_spec, spec_from_dict
from tests.support.extra_params import EXAMPLE_RATE, EXAMPLE_SCHEDULE, EXAMPLES, registered

LEGACY = json.loads((Path(__file__).resolve().parents[1] / "fixtures" / "legacy_jobs_0001.json").read_text())
FIRST_READING = importlib.import_module("backend.store.migrations.versions.0002_environment_readings").FIRST_READING

# computed on main at b32f025, before the identity rule existed
PAPER_HASHES = {
    "single": "61fbf708fa1a29ba64ad79213698c18dfb9a5fd091b216e7028381daf2acde68",
    "multi": "175cc9b9f9ea4790d3f007d189f58e13ae881de63332894be989df0c203ea569",
    "volatile": "cdecadc2e76dce71e8c008e02ec5de60c2a8847158cd654dd92d15da65920630",
    "large": "61ee060bf2e259539d9fc319560d39cc70bf92b842aeed469d6b84810983a1fa",
}
OVERRIDDEN = ({"learning_rate": 0.3, "quality_model": "exponential", "temperature": 1.0, "absent_quality": 0.2},
              "6c5e2109d1a57e87eb1a89921bfbbe60f498021082a6e1f7f83d99baa8631564")


def _hash_of(system: str, episodes: int = 100, overrides: dict | None = None, seeds: int = 1) -> str:
    return config_hash(make_spec(system, seeds=seeds, episodes=episodes, overrides=overrides).as_dict())


_VALID_BESIDE = {"topology": {"children_per_parent": 1}}
"""Other parameters a value away from the default needs on ``single`` (a sparse topology: at most its one child)."""


def _other_value(param):
    """A valid value away from ``param``'s default."""
    if param.kind == "bool":
        return not param.default
    if param.kind == "choice":
        return next(c for c in param.choices if c != param.default)
    if param.kind in ("int", "float"):
        return param.maximum if param.default != param.maximum else param.minimum
    if param.kind == "list":  # one item more than the default, at the items' smallest value
        return [*param.default, param.minimum]
    if param.kind == "events":  # one event of every field's default, or its first allowed value when required
        return [{f.name: f.default if f.default is not None else (f.choices[0] if f.choices else f.minimum)
                 for f in param.fields}]
    pytest.fail(f"{param.name}: a {param.kind} parameter has no other value here")


def test_every_parameter_of_before_issue_20_is_always_part_of_the_identity():
    before = {"n_types", "n_composite_types", "types_per_composite", "n_parents", "n_children", "resource_mean",
              "resource_sd", "value_concentration", "value_noise", "quality_model", "half_saturation",
              "load_sharing", "quality_at_uniform", "quality_floor", "learning_rate", "trace_decay", "temperature",
              "routing", "epsilon", "boltzmann_temperature", "initial_estimate", "tie_break", "leave_probability",
              "join_probability", "rejoin_profile", "absent_tasks", "absent_quality"}
    assert {p.name for p in PARAMETERS if p.identity == "always"} == before


@pytest.mark.parametrize("system", PRESETS)
def test_the_paper_configurations_keep_their_hash(system):
    if system in PAPER_HASHES:
        assert _hash_of(system) == PAPER_HASHES[system]


def test_an_overridden_configuration_keeps_its_hash():
    assert _hash_of("multi", 30, OVERRIDDEN[0], seeds=2) == OVERRIDDEN[1]


@pytest.mark.parametrize("system", sorted(PAPER_HASHES))
def test_new_parameters_at_their_default_leave_the_hash_unchanged(monkeypatch, system):
    with registered(monkeypatch):
        assert _hash_of(system) == PAPER_HASHES[system]
        spec = make_spec(system, seeds=1, episodes=100, overrides={"example_rate": 0.5, "example_schedule": []})
        assert config_hash(spec.as_dict()) == PAPER_HASHES[system]
        assert "example_rate" not in spec.as_dict()["params"]


def test_a_new_parameter_away_from_its_default_changes_the_hash_and_round_trips(monkeypatch):
    with registered(monkeypatch):
        event = [{"episode": 50, "change": "new-profiles", "fraction": 0.3}]
        for overrides in ({"example_rate": 0.25}, {"example_schedule": event}, {"example_periods": [1, 4]}):
            spec = make_spec("single", seeds=1, episodes=100, overrides=overrides)
            config = spec.as_dict()
            assert config_hash(config) != PAPER_HASHES["single"]
            assert set(config["params"]) - {p.name for p in PARAMETERS} == set(overrides)
            again = spec_from_dict(json.loads(json.dumps(config)))
            assert again == spec and config_hash(again.as_dict()) == config_hash(config)


@pytest.mark.parametrize("param", [p for p in PARAMETERS if p.identity == "when-set"], ids=lambda p: p.name)
def test_each_when_set_parameter_changes_the_hash_only_away_from_its_default(param):
    assert _hash_of("single", overrides={param.name: param.default}) == PAPER_HASHES["single"]
    beside = _VALID_BESIDE.get(param.name, {})  # what single's one child needs for the other value to be valid
    assert _hash_of("single", overrides={**beside, param.name: _other_value(param)}) != _hash_of(
        "single", overrides=beside or None)


def test_an_absent_when_set_parameter_means_its_default_not_the_presets(monkeypatch):
    with registered(monkeypatch):
        event = [{"episode": 5, "change": "frequencies", "fraction": 1.0}]
        monkeypatch.setitem(PRESETS["single"].overrides, "example_schedule", event)
        preset_job = make_spec("single", seeds=1, episodes=10)
        assert preset_job.as_dict()["params"]["example_schedule"] == event
        cleared = make_spec("single", seeds=1, episodes=10, overrides={"example_schedule": []})
        assert "example_schedule" not in cleared.as_dict()["params"]
        assert spec_from_dict(cleared.as_dict()).params.example_schedule == ()
        assert spec_from_dict(preset_job.as_dict()) == preset_job


def test_identity_and_completion_are_inverse():
    schema = (*PARAMETERS, *EXAMPLES)
    full = {p.name: p.as_dict()["default"] for p in schema} | {"example_rate": 0.9}
    stored = identity_params(full, schema)
    assert set(stored) == {p.name for p in PARAMETERS if p.identity == "always"} | {"example_rate"}
    assert complete_params(stored, schema) == full
    assert EXAMPLE_SCHEDULE.name not in identity_params({EXAMPLE_SCHEDULE.name: ()}, schema)
    assert EXAMPLE_RATE.name in identity_params({EXAMPLE_RATE.name: 0.0}, schema)


@pytest.mark.parametrize("index", range(len(LEGACY["jobs"])))
def test_legacy_jobs_keep_their_migrated_hash_when_rebuilt_today(index, monkeypatch):
    legacy = LEGACY["jobs"][index]["config"]
    migrated = dict(legacy, params=legacy["params"] | FIRST_READING)  # what revision 0002 stored
    for registering in (nullcontext, lambda: registered(monkeypatch)):
        with registering():
            rebuilt = spec_from_dict(migrated).as_dict()
            assert rebuilt["params"] == migrated["params"]
            assert config_hash(rebuilt) == config_hash(migrated)


def test_a_job_shows_every_parameter_with_the_new_ones_at_their_default(monkeypatch):
    with registered(monkeypatch):
        config = make_spec("single", seeds=1, episodes=3).as_dict()

        class Row:
            id = 1
            name = notes = ""
            tags = []
            system = "single"
            config_hash = config_hash(config)
            status = "queued"
            progress = 0.0
            attempts = 0
            error = requeue_reason = started_at = finished_at = created_at = study_id = trial_id = stopped = None
            compiling = compile_s = None
            version = "x"
            kind = "simulation"

        shown = job_dict(Row, config)["params"]
        assert shown["example_schedule"] == [] and shown["example_rate"] == 0.5 and shown["n_parents"] == 10

