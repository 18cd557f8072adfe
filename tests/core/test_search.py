"""Study plans: validation naming the field, grid cells, reproducible draws, TPE and the objectives."""

import math

import numpy as np
import pytest

from mgrao_core import ConfigError, make_spec, run_experiment
from mgrao_core.reproduction import figures_of, worst_deviation
from mgrao_core.search import MAX_TRIALS, evaluate, make_plan


def _study(**changes):
    study = {
        "name": "lr by decay", "method": "grid",
        "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3, "episodes": 20},
        "space": {"learning_rate": {"values": [0.05, 0.1, 0.2]},
                  "trace_decay": {"low": 0.5, "high": 0.95, "steps": 4}},
        "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform", "direction": "maximize"},
        "max_trials": 100, "max_in_flight": 4,
    }
    for key, value in changes.items():
        if value is None:
            study.pop(key)
        else:
            study[key] = value
    return study


def _field(study):
    with pytest.raises(ConfigError) as info:
        make_plan(study)
    return info.value.field, info.value.message


def test_the_issues_example_is_a_three_by_four_grid_in_row_major_order():
    plan = make_plan(_study())
    assert plan.planned_trials == plan.grid_size == 12
    cells = plan.suggest(0, 12)
    assert cells[0] == {"learning_rate": 0.05, "trace_decay": 0.5}
    assert cells[1] == {"learning_rate": 0.05, "trace_decay": 0.65}
    assert cells[4] == {"learning_rate": 0.1, "trace_decay": 0.5}
    assert cells[11] == {"learning_rate": 0.2, "trace_decay": 0.95}
    assert len({tuple(c.values()) for c in cells}) == 12
    assert plan.suggest(5, 3) == cells[5:8]


def test_the_definition_round_trips():
    plan = make_plan(_study())
    assert make_plan(plan.as_dict()) == plan


def test_log_ranges_step_geometrically_and_integers_stay_whole():
    plan = make_plan(_study(space={"learning_rate": {"low": 0.001, "high": 0.1, "steps": 3, "log": True},
                                   "n_parents": {"low": 10, "high": 20, "steps": 3}},
                            objective={"configuration": "mgrao-max", "metric": "final_mean"}))
    assert plan.dimensions[0].grid() == (0.001, 0.01, 0.1)
    assert plan.dimensions[1].grid() == (10, 15, 20)


def test_random_draws_depend_on_the_seed_and_the_trial_number_only():
    study = _study(method="random", space={"learning_rate": {"low": 0.001, "high": 1.0, "log": True},
                                           "trace_decay": {"low": 0.5, "high": 0.95},
                                           "routing": {"values": ["per-composite", "per-task"]}})
    plan = make_plan(study)
    draws = plan.suggest(0, 50)
    assert plan.suggest(10, 5) == draws[10:15]
    assert make_plan(study | {"seed": 1}).suggest(0, 50) != draws
    assert all(0.001 <= d["learning_rate"] <= 1.0 and 0.5 <= d["trace_decay"] <= 0.95 for d in draws)
    assert {d["routing"] for d in draws} == {"per-composite", "per-task"}
    below = sum(d["learning_rate"] < 0.0316 for d in draws)  # log-uniform: half the draws below sqrt(0.001)
    assert 15 <= below <= 35


def _toy(params):
    """A smooth objective with its maximum 0 at learning rate 0.03, trace decay 0.7."""
    return -(math.log10(params["learning_rate"] / 0.03)) ** 2 - (params["trace_decay"] - 0.7) ** 2


def _best_found(method, seed, budget):
    plan = make_plan(_study(method=method, seed=seed, max_trials=budget,
                            space={"learning_rate": {"low": 0.001, "high": 1.0, "log": True},
                                   "trace_decay": {"low": 0.05, "high": 0.99}}))
    history = []
    for number in range(budget):
        params = plan.suggest(number, 1, history)[0]
        history.append((params, _toy(params)))
    return max(value for _, value in history)


def test_tpe_beats_random_search_on_a_toy_objective():
    # 10 studies each, 40 trials: the regrets (distance below the optimum 0) are deterministic
    # for these seeds; measured with Optuna 4.x/5.0: TPE 0.0056 mean, random 0.0191. The margin:
    # TPE's mean regret must be under half of random's.
    tpe = [-_best_found("tpe", seed, 40) for seed in range(10)]
    random = [-_best_found("random", seed, 40) for seed in range(10)]
    assert np.mean(tpe) < 0.5 * np.mean(random), (tpe, random)


def test_tpe_batches_spread_out_and_repeat_for_the_same_history():
    plan = make_plan(_study(method="tpe", space={"learning_rate": {"low": 0.001, "high": 1.0, "log": True}}))
    history = [({"learning_rate": v}, _toy({"learning_rate": v, "trace_decay": 0.7}))
               for v in (0.001, 0.01, 0.03, 0.1, 0.3, 1.0, 0.002, 0.05, 0.5, 0.02, 0.04)]
    batch = plan.suggest(11, 4, history)
    assert batch == plan.suggest(11, 4, history)
    assert len({d["learning_rate"] for d in batch}) == 4


@pytest.mark.parametrize(("change", "field", "words"), [
    ({"space": {"nope": {"values": [1]}}}, "space.nope", "unknown parameter"),
    ({"space": {"learning_rate": {"values": []}}}, "space.learning_rate.values", "between 1 and"),
    ({"space": {"learning_rate": {"low": 0.5, "high": 0.1, "steps": 3}}}, "space.learning_rate", "below high"),
    ({"space": {"learning_rate": {"low": 0.1, "high": 0.1, "steps": 3}}}, "space.learning_rate", "below high"),
    ({"space": {"learning_rate": {"low": 0.1, "high": 2.0, "steps": 3}}}, "space.learning_rate.high", "[0, 1]"),
    ({"space": {"learning_rate": {"low": 0.0, "high": 0.5, "steps": 3, "log": True}}},
     "space.learning_rate.low", "above 0"),
    ({"space": {"learning_rate": {"low": 0.1, "high": 0.5}}}, "space.learning_rate.steps", "grid needs steps"),
    ({"space": {}}, "space", "at least one"),
    ({"space": {"learning_rate": {"low": 0.01, "high": 0.5, "steps": 101},
                "trace_decay": {"low": 0.1, "high": 0.9, "steps": 100}}, "max_trials": MAX_TRIALS},
     "space", "over the limit of 10,000"),
    ({"space": {"learning_rate": {"values": [0.1, 0.2]}}, "max_trials": 1}, "max_trials", "at least that"),
    ({"objective": {"configuration": "mgrao-5:1", "metric": "final_mean"}}, "objective.configuration",
     "not among the study's configurations"),
    ({"objective": {"configuration": "mgrao-max", "metric": "speed"}}, "objective.metric", "must be one of"),
    ({"objective": {"configuration": "mgrao-x:1", "metric": "final_mean"}}, "objective.configuration",
     "needs a groups dimension"),
    ({"space": {"groups": {"values": [3]}}}, "space.groups.values[0]", "does not divide n_parents = 10"),
    ({"space": {"routing": {"low": 1, "high": 2}}}, "space.routing", "takes values"),
    ({"method": "anneal"}, "method", "grid, random, tpe"),
    ({"max_in_flight": 0}, "max_in_flight", "[1, 100]"),
    ({"base": {"system": "tiny"}}, "base.system", "one of"),
    ({"base": {"system": "single", "episodes": 10**9}}, "base.episodes", "whole number in"),
    ({"base": {"system": "single", "params": {"learning_rate": 7}}}, "base.params.learning_rate", "[0, 1]"),
    ({"base": {"system": "volatile"}, "objective": {"metric": "paper_deviation"}}, None, None),
    ({"surprise": 1}, "surprise", "unknown field"),
])
def test_bad_studies_name_the_field_and_the_limit(change, field, words):
    if field is None:  # the volatile system has paper figures: a valid study
        make_plan(_study(**change))
        return
    got, message = _field(_study(**change))
    assert got == field, message
    assert words in message


def test_a_grid_whose_cells_make_invalid_experiments_is_refused():
    # 30 is a valid types_per_composite alone, but not with the single system's 20 types
    study = _study(space={"types_per_composite": {"values": [5, 30]}},
                   objective={"configuration": "mgrao-max", "metric": "final_mean"})
    field, message = _field(study)
    assert field == "space" and "not a valid experiment" in message


def test_the_objectives_read_the_named_configuration():
    plan = make_plan(_study(space={"groups": {"values": [2, 5]}},
                            base={"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3,
                                  "episodes": 20},
                            objective={"configuration": "mgrao-x:1", "metric": "pct_from_uniform"}))
    params = plan.suggest(1, 1)[0]
    (spec,) = plan.specs(params)
    assert spec.algorithms == ("uniform", "mgrao-max", "mgrao-5:1")
    summary = run_experiment(spec).summary()
    value, interval = evaluate(plan, params, {"single": summary})
    assert value == summary["mgrao-5:1"].pct_from_uniform
    assert interval == summary["mgrao-5:1"].pct_ci95


def test_the_paper_deviation_is_the_worst_over_the_systems():
    plan = make_plan(_study(base={"system": ["single", "multi"], "seeds": 4, "episodes": 100},
                            space={"half_saturation": {"values": [0.2]}},
                            objective={"metric": "paper_deviation"}))
    assert plan.objective.direction == "minimize"
    results = {spec.system: run_experiment(spec) for spec in plan.specs({"half_saturation": 0.2})}
    value, interval = evaluate(plan, {"half_saturation": 0.2}, {s: r.summary() for s, r in results.items()})
    assert value == pytest.approx(worst_deviation(results), abs=1e-12)
    figures = [f for s, r in results.items() for f in figures_of(s, r.summary())]
    assert len(figures) == 4
    assert interval is not None and interval[0] <= value <= interval[1]


def test_the_base_seeds_may_be_a_list_of_calibration_seeds():
    plan = make_plan(_study(base={"system": "single", "seeds": [10000, 10001, 10002], "episodes": 20}))
    (spec,) = plan.specs(plan.suggest(0, 1)[0])
    assert spec.seeds == (10000, 10001, 10002)
    assert spec == make_spec("single", None, [10000, 10001, 10002], 20,
                             {"learning_rate": 0.05, "trace_decay": 0.5})
    counted = make_plan(_study(base={"system": "single", "seeds": 3, "first_seed": 10000, "episodes": 20}))
    assert counted.seeds == (10000, 10001, 10002)
    assert make_plan(counted.as_dict()) == counted
    field, _ = _field(_study(base={"system": "single", "seeds": [1, 2], "first_seed": 10000}))
    assert field == "base.seeds"


@pytest.mark.parametrize(("name", "trials"), [("paper-calibration", 25), ("single-sensitivity", 36)])
def test_the_example_studies_are_valid(name, trials):
    import json
    from pathlib import Path

    study = json.loads((Path(__file__).resolve().parents[2] / "studies" / f"{name}.json").read_text())
    plan = make_plan(study)
    assert plan.planned_trials == trials
    assert make_plan(plan.as_dict()) == plan


def test_a_named_system_in_the_list_runs_its_preset_with_its_overrides_and_round_trips():
    twelve = {"name": "twelve", "system": "single", "params": {"n_parents": 12}}
    study = {"method": "grid",
             "base": {"system": ["single", twelve], "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 5,
                      "params": {"value_noise": 0.2}},
             "space": {"learning_rate": {"values": [0.1, 0.3]}},
             "objective": {"metric": "final_mean", "configuration": "mgrao-max", "system": "twelve"}}
    plan = make_plan(study)
    assert plan.systems == ("single", "twelve") and plan.preset_of("twelve") == "single"
    named = plan.named_specs({"learning_rate": 0.3})
    assert [name for name, _ in named] == ["single", "twelve"]
    assert [spec.system for _, spec in named] == ["single", "single"]
    assert [spec.params.n_parents for _, spec in named] == [10, 12]
    assert all(spec.params.value_noise == 0.2 and spec.params.learning_rate == 0.3 for _, spec in named)
    assert make_plan(plan.as_dict()) == plan
    for bad, field in ((["single", {"name": "single", "system": "single"}], "base.system[1].name"),
                       ([{"name": "x", "system": "nowhere"}], "base.system[0].system"),
                       ([{"name": "x", "system": "single", "colour": 1}], "base.system[0].colour"),
                       ([{"name": "x", "system": "single", "params": {"n_parents": 0}}],
                        "base.system.x.params.n_parents"),
                       (["single", "single"], "base.system")):
        with pytest.raises(ConfigError) as error:
            make_plan(study | {"base": study["base"] | {"system": bad}, "objective": {"metric": "final_mean",
                                                                                      "configuration": "mgrao-max"}})
        assert error.value.field == field, (bad, error.value)


def _sharing(space, configuration="mgrao-x:y", system="multi"):
    return {"name": "sharing", "method": "grid",
            "base": {"system": system, "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 5},
            "space": space, "objective": {"configuration": configuration, "metric": "pct_from_uniform"},
            "max_trials": 100}


def test_a_study_sweeps_y_beside_x():
    # issue 45: the y of mgrao-x:y (children sharing one model) is a dimension beside the group count x
    plan = make_plan(_sharing({"groups": {"values": [1, 5]}, "team_size": {"values": [1, 3]}}))
    cells = plan.suggest(0, 4)
    assert [plan.configuration_label(c) for c in cells] == ["mgrao-1:1", "mgrao-1:3", "mgrao-5:1", "mgrao-5:3"]
    assert plan.specs(cells[3])[0].algorithms == ("uniform", "mgrao-max", "mgrao-5:3")
    assert plan.specs(cells[3])[0].params == plan.specs(cells[0])[0].params  # no parameter: a configuration
    alone = make_plan(_sharing({"team_size": {"values": [3]}, "learning_rate": {"values": [0.1]}}))
    assert alone.configuration_label(alone.suggest(0, 1)[0]) == "mgrao-1:3"  # x is 1 without a groups dimension
    assert make_plan(plan.as_dict()) == plan


@pytest.mark.parametrize(("study", "field", "words"), [
    (_sharing({"team_size": {"values": [2]}}), "space.team_size.values[0]",
     "2 does not divide n_children = 3 (valid: 1, 3)"),
    (_sharing({"team_size": {"low": 1, "high": 3}}), "space.team_size", "takes values (divisors of n_children)"),
    (_sharing({"learning_rate": {"values": [0.1]}}), "objective.configuration", "needs a groups or team_size"),
    (_sharing({"groups": {"values": [2]}, "team_size": {"values": [3]}}, "mgrao-x:1"), "objective.configuration",
     "with a team_size dimension"),
])
def test_a_bad_team_size_dimension_names_the_field_and_the_valid_values(study, field, words):
    with pytest.raises(ConfigError) as error:
        make_plan(study)
    assert error.value.field == field and words in error.value.message, error.value.message
