"""The oracle: the best fixed allocation given the true expected values."""

import numpy as np
import pytest

from mgrao_core import make_spec, run_experiment
from mgrao_core.oracle import expected_type_values, oracle_weights
from mgrao_core.params import make_params
from mgrao_core.world import draw_world


def _expected_utility(params, values, weights):
    return float(np.sum(values * np.minimum(1.0, params.quality_at_uniform * params.n_types * weights)))


@pytest.mark.parametrize("overrides", [{}, {"n_parents": 50}, {"quality_at_uniform": 0.9},
                                       {"n_types": 6, "types_per_composite": 3, "n_composite_types": 2}])
def test_oracle_weights_are_an_allocation(overrides):
    params = make_params(overrides)
    for seed in range(3):
        weights = oracle_weights(params, draw_world(params, seed), seed)
        assert weights.shape == (params.n_types,)
        assert (weights >= 0).all()
        assert weights.sum() == pytest.approx(1.0, abs=1e-12)


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


def test_oracle_fills_the_most_valuable_types_first():
    params = make_params({})
    world = draw_world(params, 0)
    values = expected_type_values(params, world, 0)
    weights = oracle_weights(params, world, 0)
    full = 1 / (0.3 * 20)  # share that gives quality 1
    order = np.argsort(-values, kind="stable")
    # 1 / full = 6 types at full quality exactly fills the budget
    np.testing.assert_allclose(weights[order[:6]], full, atol=1e-12)
    np.testing.assert_allclose(weights[order[6:]], 0.0, atol=1e-12)


def test_oracle_beats_random_fixed_allocations():
    params = make_params({"n_parents": 50})
    rng = np.random.default_rng(0)
    for seed in range(3):
        world = draw_world(params, seed)
        values = expected_type_values(params, world, seed)
        best = _expected_utility(params, values, oracle_weights(params, world, seed))
        assert best >= _expected_utility(params, values, np.full(params.n_types, 1 / params.n_types))
        for w in rng.dirichlet(np.full(params.n_types, 0.3), size=200):
            assert best >= _expected_utility(params, values, w) - 1e-12


def test_oracle_spreads_the_rest_when_every_valued_type_is_full():
    # 4 types, one composite of one type: quality 1 at share 1 / (1 * 4) = 0.25; only one type has value
    params = make_params({"n_types": 4, "types_per_composite": 1, "n_composite_types": 1,
                          "quality_at_uniform": 1.0})
    world = draw_world(params, 0)
    weights = oracle_weights(params, world, 0)
    valued = int(world.parent_types[0, 0])
    # the one valued type gets the full-quality share 1/4, the remaining 3/4 is spread: + 3/16 each
    assert weights[valued] == pytest.approx(0.25 + 0.75 / 4)
    assert weights.sum() == pytest.approx(1.0)


def test_oracle_run_uses_the_oracle_weights():
    spec = make_spec("single", ["oracle"], seeds=[5], episodes=3)
    run = run_experiment(spec).runs[0]
    world = draw_world(spec.params, 5)
    np.testing.assert_array_equal(run.combined_weights[0], oracle_weights(spec.params, world, 5))
    assert run.group_weights.size == 0
