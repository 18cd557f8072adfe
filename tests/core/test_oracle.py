"""The oracle: the best fixed allocation given the true expected values."""

import numpy as np
import pytest

from mgrao_core import equations as eq
from mgrao_core import make_spec, run_experiment
from mgrao_core.oracle import expected_type_values, oracle_weights, type_loads
from mgrao_core.params import make_params
from mgrao_core.world import draw_world

LINEAR = {"quality_model": "relative-linear"}


def _expected_utility(params, values, weights, resource, loads=1.0):
    return float(np.sum(values * eq.atomic_quality(weights, resource, params, loads)))


@pytest.mark.parametrize("overrides", [{}, {"n_parents": 50}, LINEAR, LINEAR | {"quality_at_uniform": 0.9},
                                       {"quality_model": "exponential"}, {"load_sharing": True},
                                       {"n_types": 6, "types_per_composite": 3, "n_composite_types": 2},
                                       {"n_children": 3}])
def test_oracle_weights_are_an_allocation(overrides):
    params = make_params(overrides)
    for seed in range(3):
        weights = oracle_weights(params, draw_world(params, seed), seed)
        assert weights.shape == (params.n_children, params.n_types)
        assert (weights >= 0).all()
        np.testing.assert_allclose(weights.sum(axis=1), 1.0, atol=1e-12)


def test_expected_type_values_sum_to_the_parents():
    params = make_params({"n_parents": 13})
    values = expected_type_values(params, draw_world(params, 4), 4)
    # every parent's ctv sums to 1: the values over types sum to n_parents
    assert values.sum() == pytest.approx(13.0, abs=1e-9)
    assert (values >= 0).all()


def test_expected_type_values_without_noise_are_the_profiles():
    params = make_params({"value_noise": 0.0})
    world = draw_world(params, 2)
    values = expected_type_values(params, world, 2)
    expected = np.zeros(params.n_types)
    np.add.at(expected, world.parent_types.ravel(), world.profiles.ravel())
    np.testing.assert_allclose(values, expected, atol=1e-12)


def test_relative_linear_oracle_fills_the_most_valuable_types_first():
    params = make_params(LINEAR)
    world = draw_world(params, 0)
    values = expected_type_values(params, world, 0)
    weights = oracle_weights(params, world, 0)[0]
    full = 1 / (0.3 * 20)  # share that gives quality 1
    order = np.argsort(-values, kind="stable")
    # 1 / full = 6 types at full quality exactly fills the budget
    np.testing.assert_allclose(weights[order[:6]], full, atol=1e-12)
    np.testing.assert_allclose(weights[order[6:]], 0.0, atol=1e-12)


@pytest.mark.parametrize("overrides", [LINEAR | {"n_parents": 50}, {"n_parents": 50}, {"quality_model": "exponential"},
                                       {"half_saturation": 0.02}, {"half_saturation": 2.0},
                                       {"load_sharing": True, "n_parents": 30}])
def test_oracle_beats_random_fixed_allocations(overrides):
    params = make_params(overrides)
    rng = np.random.default_rng(0)
    for seed in range(3):
        world = draw_world(params, seed)
        values = expected_type_values(params, world, seed)
        loads = type_loads(params, world)
        resource = float(world.resources[0])
        best = _expected_utility(params, values, oracle_weights(params, world, seed)[0], resource, loads)
        assert best >= _expected_utility(params, values, np.full(params.n_types, 1 / params.n_types), resource, loads)
        for w in rng.dirichlet(np.full(params.n_types, 0.3), size=200):
            assert best >= _expected_utility(params, values, w, resource, loads) - 1e-12
        # no small move of weight from one type to another improves it (first-order optimality)
        weights = oracle_weights(params, world, seed)[0]
        for i, j in rng.integers(0, params.n_types, size=(100, 2)):
            moved = weights.copy()
            step = min(1e-4, moved[i])
            moved[i] -= step
            moved[j] += step
            assert best >= _expected_utility(params, values, moved, resource, loads) - 1e-12


def test_concave_oracle_equalises_marginal_values():
    # hyperbolic: V a h / (a w + h)^2 is the same for every type that gets resource
    params = make_params({"half_saturation": 0.125})
    world = draw_world(params, 1)
    values = expected_type_values(params, world, 1)
    resource = float(world.resources[0])
    weights = oracle_weights(params, world, 1)[0]
    h = params.half_saturation
    marginal = values * resource * h / (resource * weights + h) ** 2
    funded = weights > 1e-9
    assert funded.sum() >= 2
    np.testing.assert_allclose(marginal[funded], marginal[funded].mean(), rtol=1e-9)
    assert (marginal[~funded] <= marginal[funded].mean() * (1 + 1e-9)).all()


def test_each_child_gets_the_best_allocation_for_its_own_resource():
    params = make_params({"n_children": 3, "resource_sd": 0.3})
    world = draw_world(params, 3)
    weights = oracle_weights(params, world, 3)
    assert len(set(np.round(world.resources, 6))) == 3
    assert not np.allclose(weights[0], weights[1])  # hyperbolic: the resource changes the optimum
    linear = make_params(LINEAR | {"n_children": 3})
    np.testing.assert_array_equal(oracle_weights(linear, world, 3)[0], oracle_weights(linear, world, 3)[2])


def test_oracle_spreads_the_rest_when_every_valued_type_is_full():
    # 4 types, one composite of one type: quality 1 at share 1 / (1 * 4) = 0.25; only one type has value
    params = make_params(LINEAR | {"n_types": 4, "types_per_composite": 1, "n_composite_types": 1,
                                   "quality_at_uniform": 1.0})
    world = draw_world(params, 0)
    weights = oracle_weights(params, world, 0)[0]
    valued = int(world.parent_types[0, 0])
    # the one valued type gets the full-quality share 1/4, the remaining 3/4 is spread: + 3/16 each
    assert weights[valued] == pytest.approx(0.25 + 0.75 / 4)
    assert weights.sum() == pytest.approx(1.0)


def test_type_loads_count_the_instances_per_episode():
    params = make_params({"load_sharing": True, "n_parents": 30})
    world = draw_world(params, 0)
    loads = type_loads(params, world)
    expected = np.array([(world.parent_types == t).sum() for t in range(20)], dtype=float)
    assert expected.sum() == 30 * 5
    np.testing.assert_array_equal(loads, np.maximum(expected, 1.0))  # a type no parent sends counts as 1
    np.testing.assert_array_equal(type_loads(make_params({}), world), np.ones(20))


@pytest.mark.parametrize("overrides", [{"n_children": 3}, {"n_children": 3, "quality_model": "exponential"}])
def test_every_childs_oracle_row_is_optimal_for_its_own_resource(overrides):
    params = make_params(overrides | {"resource_sd": 0.3})
    rng = np.random.default_rng(1)
    for seed in range(3):
        world = draw_world(params, seed)
        values = expected_type_values(params, world, seed)
        weights = oracle_weights(params, world, seed)
        for child, resource in enumerate(world.resources):
            best = _expected_utility(params, values, weights[child], float(resource))
            for other in list(weights) + list(rng.dirichlet(np.full(params.n_types, 0.3), size=100)):
                assert best >= _expected_utility(params, values, other, float(resource)) - 1e-12


def test_oracle_run_uses_the_oracle_weights():
    spec = make_spec("multi", ["oracle"], seeds=[5], episodes=3)
    run = run_experiment(spec).runs[0]
    world = draw_world(spec.params, 5)
    np.testing.assert_array_equal(run.combined_weights, oracle_weights(spec.params, world, 5))
    assert run.group_weights.size == 0
