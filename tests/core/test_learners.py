"""The two standard learners, ``independent-q`` and ``bandit`` (issue 21 point 3): registered, equal
to their dense reference steps to 1e-12 (utilities and final weights), and deterministic however the
seeds are chunked, ordered or split into blocks."""

import numpy as np
import pytest

from mgrao_core import PARAMETERS, PRESETS, make_spec, run_experiment
from mgrao_core.algorithms import FAMILIES, KINDS, LEARNERS, describe_label, parse_algorithm, registry, sort_key
from mgrao_core.algorithms.bandit import reference as bandit_reference
from mgrao_core.budget import plan_chunks
from mgrao_core.params import make_params

from ._helpers import assert_matches_reference

LEARNER_LABELS = ["independent-q", "bandit"]
BESIDE = ["uniform", "mgrao-1:1", "independent-q", "bandit", "oracle"]


def test_both_learners_are_registered_after_the_existing_families():
    names = [f.name for f in FAMILIES]
    assert names[:3] == ["uniform", "oracle", "mgrao"]  # the codes of the others do not move
    assert [n for n in names[3:] if n in LEARNER_LABELS] == LEARNER_LABELS  # after them (mgrao-adaptive too)
    assert LEARNERS[0].name == "mgrao" and {"independent-q", "bandit"} <= {f.name for f in LEARNERS}
    assert all(KINDS[n] >= 3 for n in LEARNER_LABELS)


@pytest.mark.parametrize("label", LEARNER_LABELS)
def test_labels_parse_canonically_with_their_own_parameters(label):
    assert parse_algorithm(f"  {label.upper()} ", 10).label == label
    assert parse_algorithm(label, 10).n_groups == 0
    described = describe_label(label, PRESETS["large"].params)
    assert described["family"] == label and described["groups"] is None
    names = {p.name for p in PARAMETERS if p.group == label}
    assert names == {"independent-q": {"q_learning_rate", "q_temperature"}, "bandit": {"bandit_step"}}[label]


def test_memory_per_child_is_n_types_numbers_plus_constant_in_the_registry():
    for preset in PRESETS.values():
        n_types = preset.params.n_types
        memory = {e["name"]: e["memory_per_child"] for e in registry(preset.params)}
        assert memory["independent-q"] == {"independent-q": 8 * n_types}
        assert memory["bandit"] == {"bandit": 8 * n_types + 16}
    large = PRESETS["large"].params
    assert describe_label("mgrao-1:1", large)["memory_per_child"] > 8 * large.n_types


def test_views_order_them_after_mgrao_and_before_the_oracle():
    labels = ["oracle", "bandit", "mgrao-max", "independent-q", "uniform", "mgrao-1:1"]
    assert sorted(labels, key=sort_key) == ["uniform", "mgrao-1:1", "mgrao-max", "independent-q", "bandit", "oracle"]


def test_their_colours_differ_from_the_configurations_they_are_compared_with():
    # uniform, mgrao-1:1, mgrao-5:1, mgrao-max and the oracle: the usual company of a comparison
    company = {describe_label(label)["colour_key"] for label in ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max",
                                                                  "oracle"]}
    mine = [describe_label(label)["colour_key"] for label in LEARNER_LABELS]
    assert len(set(mine)) == 2 and not set(mine) & company


@pytest.mark.parametrize("system", ["single", "multi", "volatile", "large"])
def test_existing_configurations_have_the_learners_parameters_at_their_defaults(system):
    params = PRESETS[system].params
    defaults = {p.name: p.default for p in PARAMETERS}
    for name in ("q_learning_rate", "q_temperature", "bandit_step"):
        assert getattr(params, name) == defaults[name]


CASES = [
    ("single", {}, [0, 7]),
    ("multi", {}, [0, 7]),
    ("volatile", {}, [0, 7]),
    ("volatile", {"rejoin_profile": "new", "absent_tasks": "counted"}, [3]),
    ("large", {}, [3]),
    ("multi", {"routing": "per-task", "load_sharing": True}, [2]),
    ("multi", {"n_children": 5, "quality_model": "relative-linear"}, [4]),
    ("single", {"q_learning_rate": 1.0, "q_temperature": 0.001, "bandit_step": 50.0}, [1, 2]),
    ("single", {"q_learning_rate": 0.01, "q_temperature": 1.0, "bandit_step": 0.01}, [5]),
]


@pytest.mark.parametrize(("system", "overrides", "seeds"), CASES, ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_engine_equals_reference(system, overrides, seeds):
    spec = make_spec(system, BESIDE, seeds=seeds, episodes=40, overrides=overrides)
    assert_matches_reference(run_experiment(spec), atol=1e-12)


def test_engine_equals_reference_alone_and_on_a_long_run():
    spec = make_spec("single", LEARNER_LABELS, seeds=[11], episodes=300)
    assert_matches_reference(run_experiment(spec), atol=1e-12)


def test_the_learners_learn():
    result = run_experiment(make_spec("single", ["uniform", *LEARNER_LABELS], seeds=[0, 1], episodes=40))
    for run in result.runs:
        spread = np.ptp(run.combined_weights)
        assert (spread == 0) == (run.algorithm == "uniform"), run.algorithm
        np.testing.assert_allclose(run.combined_weights.sum(axis=1), 1.0, rtol=0, atol=1e-12)


def test_the_bandits_reference_pulls_under_the_allocation_in_force():
    child = bandit_reference.Child(make_params({"n_types": 4, "types_per_composite": 2, "bandit_step": 2.0}))
    w = child.allocation()  # uniform: H is 0
    child.learn(0, 1, 0.5)  # first value: the baseline is that value, so nothing moves
    assert np.array_equal(child.h, np.zeros(4))
    child.learn(0, 2, 0.1)  # baseline 0.3, advantage 2 * (0.1 - 0.3) = -0.4
    np.testing.assert_allclose(child.h, [0.4 * w[0], 0.4 * w[1], -0.4 * (1 - w[2]), 0.4 * w[3]], rtol=0, atol=1e-15)
    assert abs(child.h.sum()) < 1e-15  # a gradient step keeps the preferences' sum


def _by_run(result):
    return {(r.algorithm, r.seed): (r.utilities, r.combined_weights) for r in result.runs}


def _assert_same(a, b):
    assert a.keys() <= b.keys() or b.keys() <= a.keys()
    for key in a.keys() & b.keys():
        assert np.array_equal(a[key][0], b[key][0]), key
        assert np.array_equal(a[key][1], b[key][1]), key


@pytest.mark.parametrize("system", ["single", "multi", "volatile", "large"])
def test_same_numbers_however_seeds_are_chunked_ordered_or_split(system):
    spec = make_spec(system, LEARNER_LABELS + ["uniform"], seeds=[4, 1, 9], episodes=20)
    whole = _by_run(run_experiment(spec))
    assert len(plan_chunks(spec, budget=1)) == 3  # one seed per chunk under a tiny budget
    _assert_same(whole, _by_run(run_experiment(spec, memory_budget=1)))
    _assert_same(whole, _by_run(run_experiment(spec, episodes_per_block=3)))
    _assert_same(whole, _by_run(run_experiment(make_spec(system, LEARNER_LABELS, seeds=[9, 4, 1], episodes=20))))
    for seed in (1, 9):  # one seed, both learners without uniform (the signature of their long reference run)
        alone = _by_run(run_experiment(make_spec(system, LEARNER_LABELS, seeds=[seed], episodes=20)))
        _assert_same(whole, alone)
        assert len(alone) == 2


def test_same_numbers_beside_any_other_algorithm():
    few = _by_run(run_experiment(make_spec("large", LEARNER_LABELS, seeds=[3], episodes=15)))
    full = _by_run(run_experiment(make_spec("large", ["uniform", "mgrao-25:1", "mgrao-max", "bandit",
                                                      "independent-q", "oracle"], seeds=[3], episodes=15)))
    _assert_same(few, full)
