"""Several resources (issue 20, point 1): docs/model.md ("Several resources").

The engine against the dense reference (1e-12 on utilities, each resource's final PW and allocation) for two
and three resources under both combinations and both credits, every family; one resource gives today's numbers
bit for bit whatever the new parameters say; the draws leave the existing streams untouched; the quality
combination's two forms agree; determinism over chunks and blocks; bad input names the field and the limit.
"""

import numpy as np
import pytest

from mgrao_core import ConfigError, make_params, make_spec, run_experiment
from mgrao_core.env import parallel_env
from mgrao_core.presets import PAPER_SYSTEMS, PRESETS
from mgrao_core.quality import (
    RESOURCE_COMBINATION_CODES,
    combine_resources,
    compiled_combined_resources,
    single_split_resource,
)
from mgrao_core.reference import SeedEnvironment
from mgrao_core.world import EpisodeStreams, draw_world

from ._helpers import assert_resources_match_reference

ALGORITHMS = ["uniform", "oracle", "mgrao-1:1", "mgrao-2:1", "mgrao-max", "mgrao-adaptive:2", "independent-q",
              "bandit"]
SETTINGS = [(r, combination, credit) for r in (2, 3) for combination in ("scarcest", "weighted")
            for credit in ("shared", "by-share")]


@pytest.mark.parametrize(("n_resources", "combination", "credit"), SETTINGS)
@pytest.mark.parametrize("system", ["single", "multi"])
def test_engine_equals_reference(system, n_resources, combination, credit):
    overrides = {"n_resources": n_resources, "resource_combination": combination, "resource_credit": credit}
    spec = make_spec(system, ALGORITHMS, seeds=[0, 5], episodes=15, overrides=overrides)
    assert_resources_match_reference(run_experiment(spec))


@pytest.mark.parametrize("overrides", [
    {"quality_model": "exponential", "capability_spread": 0.5, "load_sharing": True},
    {"quality_model": "relative-linear", "routing": "per-task", "need_concentration": 0.2},
    {"leave_probability": 0.25, "join_probability": 0.25, "absent_tasks": "counted", "unpredictable_fraction": 0.2,
     "frequency_profile": "two-speed"},
])
@pytest.mark.parametrize("combination", ["scarcest", "weighted"])
def test_engine_equals_reference_under_other_readings(overrides, combination):
    spec = make_spec("multi", ALGORITHMS, seeds=[1], episodes=12,
                     overrides={**overrides, "n_resources": 3, "resource_combination": combination,
                                "resource_credit": "by-share"})
    assert_resources_match_reference(run_experiment(spec))


def test_bounded_learner_equals_reference_with_resources():
    # more than MIN_BOUNDED_GROUPS groups: the bounded lazy update, one per resource
    overrides = {"n_parents": 80, "types_per_composite": 3, "n_resources": 2, "resource_credit": "by-share",
                 "resource_combination": "weighted"}
    spec = make_spec("single", ["uniform", "mgrao-max"], seeds=[3], episodes=15, overrides=overrides)
    assert_resources_match_reference(run_experiment(spec))


def _numbers(result):
    return [(r.algorithm, r.seed, r.utilities.tobytes(), r.group_weights.tobytes(), r.combined_weights.tobytes())
            for r in result.runs]


@pytest.mark.parametrize("overrides", [
    {"resource_combination": "weighted"}, {"resource_credit": "by-share"}, {"need_concentration": 0.05},
    {"resource_combination": "weighted", "resource_credit": "by-share", "need_concentration": 7.0},
])
def test_one_resource_is_todays_numbers_bit_for_bit(overrides):
    # with one resource the new parameters change nothing: not a draw, not a bit
    for system in ("single", "multi"):
        today = make_spec(system, ALGORITHMS, seeds=[0, 2], episodes=12)
        one = make_spec(system, ALGORITHMS, seeds=[0, 2], episodes=12, overrides={**overrides, "n_resources": 1})
        result = run_experiment(one)
        assert _numbers(result) == _numbers(run_experiment(today))
        assert all(r.resource_weights is None and r.resource_group_weights is None for r in result.runs)


def test_the_first_resource_and_every_other_stream_are_todays_draws():
    today = make_params()
    several = make_params({"n_resources": 4})
    for seed in (0, 9):
        a, b = draw_world(today, seed), draw_world(several, seed)
        for name in ("composite_types", "parent_types", "profiles", "resources", "capability"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        np.testing.assert_array_equal(b.amounts[:, 0], a.resources)
        assert b.amounts.shape == (1, 4) and b.needs.shape == (20, 4)
        assert ((b.amounts > 0) & (b.amounts <= 1)).all()
        np.testing.assert_allclose(b.needs.sum(axis=1), 1.0, rtol=0, atol=1e-15)
        assert a.amounts is None and a.n_resources == 1
        np.testing.assert_array_equal(a.type_resources, a.resource_per_type[:, 0])
        da, db = EpisodeStreams(today, seed).draw(5), EpisodeStreams(several, seed).draw(5)
        for name in ("noise", "order", "volatility", "routing"):
            np.testing.assert_array_equal(getattr(da, name), getattr(db, name))


def test_needs_follow_their_concentration():
    flat = draw_world(make_params({"n_resources": 3, "need_concentration": 100.0}), 0).needs
    spiky = draw_world(make_params({"n_resources": 3, "need_concentration": 0.05}), 0).needs
    assert np.abs(flat - 1 / 3).max() < 0.15
    assert spiky.max(axis=1).mean() > 0.9


def test_one_resource_combination_is_the_resource_itself():
    rng = np.random.default_rng(0)
    w, a = rng.random((50, 1)), rng.random((50, 1))
    for combination in ("scarcest", "weighted"):
        w_eff, a_eff, shares = combine_resources(w, a, np.ones((50, 1)), combination)
        np.testing.assert_array_equal(w_eff, w[:, 0])
        np.testing.assert_array_equal(a_eff, a[:, 0])
        np.testing.assert_array_equal(shares, 1.0)


@pytest.mark.parametrize("combination", ["scarcest", "weighted"])
def test_compiled_and_numpy_combinations_agree(combination):
    compiled = compiled_combined_resources()
    from numba import njit

    @njit
    def run(w, a, needs, code, shares):
        out = np.zeros((w.shape[0], 2))
        for i in range(w.shape[0]):
            out[i, 0], out[i, 1] = compiled(w[i], a[i], needs[i], code, shares[i])
        return out

    rng = np.random.default_rng(1)
    w, a = rng.random((200, 3)), rng.random((200, 3)) * 4
    needs = rng.dirichlet(np.ones(3), size=200)
    w[:5] = 0.0  # a resource not given at all
    shares = np.zeros((200, 3))
    out = run(w, a, needs, RESOURCE_COMBINATION_CODES[combination], shares)
    w_eff, a_eff, numpy_shares = combine_resources(w, a, needs, combination)
    np.testing.assert_allclose(out[:, 0], w_eff, rtol=1e-15, atol=0)
    np.testing.assert_allclose(out[:, 1], a_eff, rtol=1e-15, atol=0)
    np.testing.assert_array_equal(shares, numpy_shares)
    np.testing.assert_allclose(shares.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    if combination == "scarcest":  # the limiting resource decides
        np.testing.assert_array_equal(w_eff * a_eff, (w * a).min(axis=1))


@pytest.mark.parametrize("combination", ["scarcest", "weighted"])
def test_one_split_for_every_resource_is_one_effective_resource(combination):
    # what the oracle allocates: w * min_r a_r (scarcest), w * prod_r a_r ** need_r (weighted)
    world = draw_world(make_params({"n_resources": 3, "resource_combination": combination, "n_children": 2}), 4)
    per_weight = world.resource_per_type
    w = np.random.default_rng(2).dirichlet(np.ones(20))
    weights = np.broadcast_to(w[None, :, None], (2, 20, 3))
    w_eff, a_eff, _ = combine_resources(weights, per_weight.transpose(0, 2, 1), world.needs[None], combination)
    np.testing.assert_allclose(w_eff * a_eff, w * single_split_resource(per_weight, world.needs, combination),
                               rtol=1e-13)
    np.testing.assert_array_equal(world.type_resources, single_split_resource(per_weight, world.needs, combination))


def test_shared_credit_keeps_every_resource_pw_identical_and_by_share_does_not():
    spec = make_spec("multi-resource", ["mgrao-1:1", "mgrao-max"], seeds=[0, 1], episodes=20)
    for run in run_experiment(spec).runs:
        np.testing.assert_array_equal(run.resource_group_weights[0], run.resource_group_weights[1])
    spec = make_spec("multi-resource", ["mgrao-1:1"], seeds=[0], episodes=20,
                     overrides={"resource_credit": "by-share"})
    run = run_experiment(spec).runs[0]
    assert np.abs(run.resource_group_weights[0] - run.resource_group_weights[1]).max() > 1e-3


def test_chunks_and_blocks_change_no_number():
    spec = make_spec("multi", ALGORITHMS, seeds=[0, 1, 2], episodes=15,
                     overrides={"n_resources": 3, "resource_credit": "by-share", "resource_combination": "weighted"})

    def numbers(result):
        return _numbers(result) + [(r.resource_weights.tobytes(), None if r.resource_group_weights is None else
                                    r.resource_group_weights.tobytes()) for r in result.runs]

    whole = numbers(run_experiment(spec))
    assert numbers(run_experiment(spec)) == whole
    assert numbers(run_experiment(spec, episodes_per_block=4)) == whole
    assert numbers(run_experiment(spec, memory_budget=1)) == whole


def test_the_preset_is_beside_the_papers_four():
    preset = PRESETS["multi-resource"]
    assert "multi-resource" not in PAPER_SYSTEMS
    assert preset.params.n_resources == 2 and preset.params.n_children == 1
    assert preset.description and "\n" not in preset.description


@pytest.mark.parametrize("combination", ["scarcest", "weighted"])
def test_the_pettingzoo_environment_takes_one_allocation_per_resource(combination):
    env = parallel_env("multi-resource", seed=4, episodes=6, resource_combination=combination)
    p = env.params
    assert env.action_space("child_0").shape == (p.n_resources, p.n_types)
    observations, _ = env.reset()
    world = draw_world(p, 4)
    np.testing.assert_array_equal(observations["child_0"]["resources"], world.resource_per_type[0])
    reference = SeedEnvironment(p, 4)
    rng = np.random.default_rng(0)
    while env.agents:
        action = rng.random((p.n_resources, p.n_types))  # each resource its own split
        observations, rewards, _, _, infos = env.step({"child_0": action})
        episode = reference.step([env.allocation(action)])
        assert infos["child_0"]["utility"] == pytest.approx(episode.utility, abs=1e-12)
        np.testing.assert_array_equal(observations["child_0"]["allocation"], env.allocation(action))
    with pytest.raises(ValueError, match="for each resource"):
        env.reset()
        env.step({"child_0": np.ones(p.n_types)})


def test_more_resources_count_in_the_group_updates():
    one = make_spec("single", ["mgrao-max", "uniform", "mgrao-adaptive:2"], seeds=[0], episodes=10)
    several = make_spec("single", ["mgrao-max", "uniform", "mgrao-adaptive:2"], seeds=[0], episodes=10,
                        overrides={"n_resources": 4})
    assert several.group_updates == one.group_updates + 3 * 10 * 10 * 5 * 10


@pytest.mark.parametrize(("overrides", "field", "message"), [
    ({"n_resources": 0}, "n_resources", "must be in [1, 8] (got 0)"),
    ({"n_resources": 9}, "n_resources", "must be in [1, 8] (got 9)"),
    ({"n_resources": 1.5}, "n_resources", "whole number"),
    ({"need_concentration": 0}, "need_concentration", "[0.01, 100]"),
    ({"need_concentration": 1000}, "need_concentration", "[0.01, 100]"),
    ({"resource_combination": "sum"}, "resource_combination", "must be one of scarcest, weighted"),
    ({"resource_credit": "equal"}, "resource_credit", "must be one of shared, by-share"),
])
def test_bad_input_names_the_field_and_the_limit(overrides, field, message):
    with pytest.raises(ConfigError) as info:
        make_params(overrides)
    assert info.value.field == field
    assert message in info.value.message


@pytest.mark.parametrize("n_resources", [1, 2, 8])
def test_the_budget_bounds_what_a_chunk_allocates(n_resources):
    # what numpy allocates while a chunk runs (tracemalloc sees every array of the runner and the oracle)
    # stays within what budget.chunk_cost counts for it, at every number of resources
    import tracemalloc

    from mgrao_core.budget import chunk_cost
    from mgrao_core.runner import run_chunk

    spec = make_spec("multi", ALGORITHMS, seeds=[0, 1, 2], episodes=30,
                     overrides={"n_resources": n_resources, "resource_credit": "by-share"})
    run_chunk(spec, spec.seeds)  # compiled already: the peak is the chunk's own
    tracemalloc.start()
    try:
        run_chunk(spec, spec.seeds)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= chunk_cost(spec, len(spec.seeds)).total
