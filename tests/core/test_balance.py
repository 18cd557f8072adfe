"""mgrao-balance: its labels, its compiled steps against its dense reference step, its rule, determinism."""

import numpy as np
import pytest

from mgrao_core import ConfigError, get_preset, make_params, make_spec, parse_algorithm, reference, run_experiment
from mgrao_core.algorithms import FAMILIES_BY_NAME, describe_label, sort_key, task_share
from mgrao_core.algorithms.balance import next_split
from mgrao_core.algorithms.mgrao import parent_groups
from tests.core._helpers import assert_matches_reference, assert_resources_match_reference

FAMILY = FAMILIES_BY_NAME["mgrao-balance"]
LABELS = ["mgrao-1:1", "mgrao-balance", "mgrao-balance:2"]  # one kernel signature (MG-RAO's and balance's lanes) for
# every test with one resource: a signature costs a compile of the kernel, the runs are cheap


def test_labels_bare_and_bounded():
    bare = parse_algorithm(" MGRAO-BALANCE", 50)
    assert (bare.label, bare.kind, bare.n_groups) == ("mgrao-balance", "mgrao-balance", 50)  # mgrao-max's memory
    assert parse_algorithm("mgrao-balance:010", 50).label == "mgrao-balance:10"
    assert parse_algorithm("mgrao-balance:10", 50).n_groups == 10
    for bad in ("mgrao-balance:0", "mgrao-balance:3", "mgrao-balance:60"):
        with pytest.raises(ConfigError) as info:
            parse_algorithm(bad, 50, "algorithms[1]")
        assert info.value.field == "algorithms[1]" and "divisor of n_parents = 50" in info.value.message
    with pytest.raises(ConfigError, match="mgrao-balance or mgrao-balance:M"):
        parse_algorithm("mgrao-balance:x", 50)
    assert describe_label("mgrao-balance:5")["groups"] == 5
    assert FAMILY.examples(50) == ["mgrao-balance", "mgrao-balance:10"]
    assert FAMILY.examples(10) == ["mgrao-balance"]
    assert FAMILY.forms(10)[1]["valid"] == [1, 2, 5, 10]
    labels = ["mgrao-balance", "oracle", "mgrao-max", "mgrao-adaptive:2", "mgrao-balance:5", "uniform"]
    assert sorted(labels, key=sort_key) == ["uniform", "mgrao-max", "mgrao-adaptive:2", "mgrao-balance:5",
                                            "mgrao-balance", "oracle"]


def test_the_ladder_of_splits_is_nested():
    assert [next_split(m, 50) for m in (1, 2, 10)] == [2, 5, 5]  # 1, 2, 10, 50 groups
    assert [next_split(m, 10) for m in (1, 2)] == [2, 5]
    assert next_split(1, 7) == 7
    for groups, then in ((1, 2), (2, 10), (10, 50)):  # each new group lies inside one old group
        old, new = parent_groups(50, groups), parent_groups(50, then)
        assert all(len(set(old[new == g])) == 1 for g in range(then))


def test_memory_grows_with_the_bound_and_the_share_with_the_groups():
    params = get_preset("large").params
    memory = [FAMILY.memory_per_child(parse_algorithm(label, 50), params)
              for label in ("mgrao-balance:2", "mgrao-balance:10", "mgrao-balance")]
    most = FAMILIES_BY_NAME["mgrao"].memory_per_child(parse_algorithm("mgrao-max", 50), params)
    assert memory[0] < memory[1] < memory[2]
    assert memory[2] - most == 3 * 8 + 1  # max's rows; its groups, last split, episodes begun and whether it settled
    assert FAMILY.learned_for(3, params) == 3 * (2 * params.n_types + 1) + 2
    costly = make_params({"learning_cost": 0.2}, base=params)
    assert task_share(parse_algorithm("mgrao-balance:10", 50), costly) == 1.0 - 0.2 * (10 * 41 + 2) / (50 * 41)


def _check_history(result):
    """Each run's recorded groups are those of the reference's children after each decision."""
    spec = result.spec
    for run in result.runs:
        if run.membership is None:  # mgrao-1:1
            continue
        _, children = reference.simulate(spec.params, run.algorithm, run.seed, spec.episodes)
        step = run.membership_every // spec.params.balance_every
        for c, child in enumerate(children):
            expected = np.stack([parent_groups(spec.params.n_parents, m) for m in child.history[::step]])
            np.testing.assert_array_equal(run.membership[c], expected[: run.membership.shape[1]],
                                          err_msg=f"{run.algorithm} seed {run.seed}")


@pytest.mark.parametrize(("system", "seeds", "episodes", "overrides"), [
    ("single", [0, 7], 40, {"learning_cost": 0.1, "balance_every": 5}),
    ("single", [2], 30, {"learning_cost": 0.5, "balance_every": 3, "balance_tolerance": 2.0}),
    ("single", [3], 30, {"balance_every": 4}),  # no cost: splits up to the bound
    ("multi", [1], 30, {"learning_cost": 0.3, "balance_every": 4, "routing": "per-task"}),
    ("volatile", [3, 4], 40, {"learning_cost": 0.1, "balance_every": 5}),
    ("large", [5], 30, {"learning_cost": 0.25, "balance_tolerance": 1.0}),
    ("single", [1], 20, {"learning_cost": 0.2, "quality_model": "relative-linear", "balance_tolerance": 3.0,
                         "balance_every": 2}),
    ("multi", [6], 20, {"load_sharing": True, "quality_model": "exponential", "learning_cost": 0.1,
                        "balance_every": 2, "balance_tolerance": 0.5}),
])
def test_engine_matches_the_dense_reference(system, seeds, episodes, overrides):
    result = run_experiment(make_spec(system, LABELS, seeds=seeds, episodes=episodes, overrides=overrides))
    assert_matches_reference(result)
    _check_history(result)
    assert any((run.membership[:, -1] != 0).any() for run in result.runs if run.membership is not None)  # a split


def test_past_the_bounded_rows_the_engine_still_matches():
    """128 parents, a decision every episode and no cost: 1, 2, 4 ... 128 groups, crossing MG-RAO's bounded form."""
    result = run_experiment(make_spec("single", LABELS, seeds=[0], episodes=12,
                                      overrides={"n_parents": 128, "balance_every": 1}))
    assert_matches_reference(result)
    assert result.runs[1].membership[0, -1].max() + 1 == 128


def test_several_resources_one_split_for_every_resource():
    spec = make_spec("multi-resource", ["mgrao-balance", "mgrao-balance:2"], seeds=[0, 2], episodes=20,
                     overrides={"learning_cost": 0.2, "balance_every": 4, "resource_credit": "by-share"})
    assert_resources_match_reference(run_experiment(spec))


def test_the_rule_settles_under_a_cost_and_reaches_the_bound_without_one():
    free = run_experiment(make_spec("single", LABELS, seeds=[0, 1], episodes=30, overrides={"balance_every": 5}))
    assert all(run.membership[c, -1].max() + 1 == (10 if run.algorithm == "mgrao-balance" else 2)
               for run in free.runs if run.membership is not None for c in range(run.membership.shape[0]))
    strict = run_experiment(make_spec("single", LABELS, seeds=[0, 1], episodes=30,
                                      overrides={"balance_every": 5, "learning_cost": 0.5,
                                                 "balance_tolerance": 1_000_000.0}))
    assert all(run.membership[0, -1].max() + 1 == 2  # the first split, then it settles
               for run in strict.runs if run.membership is not None)


def test_a_bound_of_one_group_is_mgrao_one_to_one_bit_for_bit():
    spec = make_spec("large", [*LABELS, "mgrao-balance:1"], seeds=[0, 1], episodes=25)
    by = {(r.algorithm, r.seed): r for r in run_experiment(spec).runs}
    for seed in (0, 1):
        fixed, balance = by[("mgrao-1:1", seed)], by[("mgrao-balance:1", seed)]
        assert fixed.utilities.tobytes() == balance.utilities.tobytes()
        assert fixed.combined_weights.tobytes() == balance.combined_weights.tobytes()


def _by_run(result):
    return {(r.algorithm, r.seed): (r.utilities.tobytes(), r.combined_weights.tobytes(),
                                    b"" if r.membership is None else r.membership.tobytes()) for r in result.runs}


def test_deterministic_whatever_runs_beside_it_and_whatever_the_blocks():
    labels = LABELS
    overrides = {"balance_every": 3, "learning_cost": 0.1}
    spec = make_spec("volatile", labels, seeds=[4, 1, 9], episodes=22, overrides=overrides)
    whole = _by_run(run_experiment(spec))
    assert whole == _by_run(run_experiment(spec))
    assert whole == _by_run(run_experiment(spec, episodes_per_block=5))
    reordered = _by_run(run_experiment(make_spec("volatile", labels[::-1], seeds=[9, 1, 4], episodes=22,
                                                 overrides=overrides)))
    assert whole == reordered
    beside = ["mgrao-balance", "mgrao-adaptive:3"]  # no MG-RAO lanes: one kernel for both tests
    alone = _by_run(run_experiment(make_spec("volatile", beside, seeds=[1], episodes=22,
                                             overrides=overrides)))
    assert alone[("mgrao-balance", 1)] == whole[("mgrao-balance", 1)]


@pytest.mark.parametrize(("field", "value", "limit"), [
    ("balance_every", 0, "1"), ("balance_every", 2.5, "whole"), ("balance_tolerance", -1.0, "0"),
    ("balance_tolerance", float("nan"), "finite"),
])
def test_bad_values_are_refused_naming_the_field(field, value, limit):
    with pytest.raises(ConfigError) as info:
        make_spec("single", ["mgrao-balance"], seeds=1, overrides={field: value})
    assert info.value.field == field and limit in info.value.message
