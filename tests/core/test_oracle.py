"""The oracle: the best fixed allocation given the true expected values."""

import numpy as np
import pytest

from mgrao_core import Cancelled, make_spec, run_experiment
from mgrao_core import equations as eq
from mgrao_core.budget import ORACLE_BATCH, ORACLE_DRAWS
from mgrao_core.oracle import EXPECTATION_SAMPLES, expected_type_values, oracle_weights, type_loads
from mgrao_core.params import make_params
from mgrao_core.world import draw_world, stream

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


def _plain_numpy_expected_type_values(params, world, seed):
    """The estimate as earlier versions computed it, in plain numpy: the reference for the compiled one."""
    rng = stream(seed, "oracle")
    expected = np.zeros_like(world.profiles)
    remaining = EXPECTATION_SAMPLES
    while remaining:
        batch = min(remaining, ORACLE_BATCH)
        noisy = world.profiles * np.exp(params.value_noise * rng.standard_normal((batch,) + world.profiles.shape))
        expected += (noisy / noisy.sum(axis=2, keepdims=True)).sum(axis=0)
        remaining -= batch
    expected /= EXPECTATION_SAMPLES
    values = np.zeros(params.n_types)
    np.add.at(values, world.parent_types.ravel(), expected.ravel())
    return values


# (system, overrides, the last child's three largest weights and sum_t (t + 1) * w[c, t] over every
# child, for seed 7, as the plain numpy oracle computed them before the estimate was compiled)
EARLIER_WEIGHTS = [
    ("single", {}, [0.37056447680537297, 0.3218887187821621, 0.28173229698494817], 10.89576419161601),
    ("multi", {}, [0.22869861577705608, 0.21279061827776963, 0.199666872835002], 35.63958672382397),
    ("volatile", {"rejoin_profile": "new"}, [0.37056447680537297, 0.3218887187821621, 0.28173229698494817],
     10.89576419161601),
    ("large", {"quality_model": "exponential"}, [0.26850403951833696, 0.2052116316289399, 0.16858978803096636],
     12.58279342876716),
    ("single", {"quality_model": "relative-linear", "routing": "per-task"},
     [0.16666666666666666, 0.16666666666666666, 0.16666666666666666], 9.166666666666668),
    ("multi", {"load_sharing": True}, [0.28856497832402306, 0.27093591538447315, 0.19027847704853276],
     21.769501138865813),
    ("single", {"value_noise": 5.0, "value_concentration": 0.01},
     [0.26248864257882726, 0.1898947164111858, 0.11314577263706373], 9.069083026438872),
    ("single", {"value_noise": 0.0}, [0.3720880805379415, 0.32175598232988123, 0.28011069297415747],
     10.910636994412227),
    ("single", {"n_types": 200, "types_per_composite": 200, "n_parents": 20, "n_composite_types": 20},
     [0.07011255162925975, 0.06594486674818745, 0.06212319205023278], 108.46759750130352),
    ("multi", {"n_types": 150, "types_per_composite": 129, "n_parents": 7, "quality_model": "exponential"},
     [0.18682260377273793, 0.15817266654432569, 0.13622540153477714], 217.81024679845333),
    ("single", {"n_types": 9, "types_per_composite": 8, "load_sharing": True},
     [0.6814316193402359, 0.13657346632810005, 0.1204586740696249], 4.4775370800157015),
    ("single", {"n_types": 2, "types_per_composite": 1, "quality_model": "relative-linear"}, [1.0, 0.0], 1.0),
]


@pytest.mark.parametrize(("system", "overrides"), [(system, overrides) for system, overrides, _, _ in EARLIER_WEIGHTS])
def test_expected_type_values_are_the_plain_numpy_estimate_bit_for_bit(system, overrides):
    # the same draws, the same operations in the same order: stored oracle runs re-run to the bit
    params = make_spec(system, ["oracle"], seeds=1, episodes=1, overrides=overrides).params
    for seed in (0, 1, 7):
        world = draw_world(params, seed)
        np.testing.assert_array_equal(expected_type_values(params, world, seed),
                                      _plain_numpy_expected_type_values(params, world, seed))


@pytest.mark.parametrize(("system", "overrides", "largest", "weighted_sum"), EARLIER_WEIGHTS)
def test_oracle_weights_are_those_of_earlier_versions(system, overrides, largest, weighted_sum):
    params = make_spec(system, ["oracle"], seeds=1, episodes=1, overrides=overrides).params
    weights = oracle_weights(params, draw_world(params, 7), 7)
    np.testing.assert_allclose(np.sort(weights[-1])[::-1][:3], largest, rtol=1e-12, atol=0)
    assert float((weights * np.arange(1, params.n_types + 1)).sum()) == pytest.approx(weighted_sum, rel=1e-12)


LARGE = {"n_parents": 1000, "n_types": 200, "types_per_composite": 200}


def test_a_large_oracle_stops_at_the_check_that_returns_true():
    params = make_spec("large", ["oracle"], seeds=1, episodes=1, overrides=LARGE).params
    calls = []

    def stop_on_fifth_check() -> bool:
        calls.append(1)
        return len(calls) == 5

    with pytest.raises(Cancelled, match="oracle's values for seed 3"):
        oracle_weights(params, draw_world(params, 3), 3, should_stop=stop_on_fifth_check)
    assert len(calls) == 5


def test_a_large_oracle_checks_for_a_stop_every_few_noise_values():
    # between two checks it draws at most ORACLE_DRAWS noise values, or one sample when that is more
    params = make_spec("large", ["oracle"], seeds=1, episodes=1, overrides=LARGE).params
    calls = []
    world = draw_world(params, 3)
    values = expected_type_values(params, world, 3, should_stop=lambda: calls.append(1) or False)
    per_sample = params.n_parents * params.types_per_composite
    assert len(calls) * max(ORACLE_DRAWS, per_sample) >= EXPECTATION_SAMPLES * per_sample
    assert values.sum() == pytest.approx(params.n_parents, rel=1e-12)
