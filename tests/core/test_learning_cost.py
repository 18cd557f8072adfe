"""The cost of learning (issue 33): learning takes a share of each child's resources, what it keeps sets the share.

docs/model.md ("The cost of learning") defines it: a child whose algorithm learns ``L`` numbers gives its tasks
``task_share = 1 - min(1, learning_cost * L / L_max)`` of its allocation, ``L_max`` being what ``mgrao-max`` keeps.
"""

import numpy as np
import pytest

from mgrao_core import ConfigError, make_params, make_spec, run_experiment
from mgrao_core import equations as eq
from mgrao_core.algorithms import FAMILIES_BY_NAME, learned_by_max, parse_algorithm, task_share
from mgrao_core.algorithms.base import Family
from mgrao_core.env import parallel_env, vector_env
from mgrao_core.presets import PRESETS
from mgrao_core.statistics.pairing import own_values, world_digest

from ._helpers import assert_matches_reference, assert_resources_match_reference

LEARNERS = ["mgrao-1:1", "mgrao-2:1", "mgrao-max", "mgrao-adaptive:2", "independent-q", "bandit"]
ALGORITHMS = ["uniform", "oracle", *LEARNERS]


def _numbers(result):
    return [(r.algorithm, r.seed, r.utilities.tobytes(), r.combined_weights.tobytes()) for r in result.runs]


@pytest.mark.parametrize(("system", "overrides"), [
    ("single", {}),
    ("multi", {"routing": "per-task"}),
    ("multi", {"load_sharing": True, "quality_model": "exponential"}),
    ("single", {"quality_model": "relative-linear"}),
    ("multi-resource", {"resource_combination": "weighted", "resource_credit": "by-share"}),
])
@pytest.mark.parametrize("cost", [0.3, 1.0])
def test_the_engine_equals_the_reference_under_a_learning_cost(system, overrides, cost):
    spec = make_spec(system, ALGORITHMS, seeds=[0, 4], episodes=15, overrides={**overrides, "learning_cost": cost})
    check = assert_matches_reference if spec.params.n_resources == 1 else assert_resources_match_reference
    check(run_experiment(spec))


def test_no_cost_is_todays_numbers_bit_for_bit():
    for system in ("single", "multi", "multi-resource"):
        today = run_experiment(make_spec(system, ALGORITHMS, seeds=[0, 3], episodes=12))
        zero = run_experiment(make_spec(system, ALGORITHMS, seeds=[0, 3], episodes=12,
                                        overrides={"learning_cost": 0.0}))
        assert _numbers(zero) == _numbers(today)
        assert make_params({"learning_cost": 0}).as_config() == make_params({}).as_config()  # the same configuration


def test_what_learns_nothing_pays_nothing_and_the_rest_pay_for_what_they_keep():
    spec = make_spec("large", ALGORITHMS, seeds=[1, 2], episodes=20)
    free = {(r.algorithm, r.seed): r.utilities for r in run_experiment(spec).runs}
    costly = run_experiment(make_spec("large", ALGORITHMS, seeds=[1, 2], episodes=20,
                                      overrides={"learning_cost": 0.5}))
    for run in costly.runs:
        same = run.utilities.tobytes() == free[run.algorithm, run.seed].tobytes()
        assert same == (run.algorithm in ("uniform", "oracle")), run.algorithm
    max_free = np.mean([free["mgrao-max", s] for s in (1, 2)])
    max_costly = np.mean([r.utilities for r in costly.runs if r.algorithm == "mgrao-max"])
    assert max_costly < 0.9 * max_free  # half its resource to learning: its tasks do clearly worse


def test_the_share_follows_the_numbers_each_family_keeps():
    params = make_params({"learning_cost": 0.4}, base=make_spec("large", ["uniform"], seeds=1).params)
    n, parents = params.n_types, params.n_parents  # 20 types, 50 parents

    def share(label):
        return task_share(parse_algorithm(label, parents), params)

    by_max = parents * (2 * n + 1)
    assert share("mgrao-max") == 1.0 - 0.4  # the paper's "unlimited" learning pays the whole cost
    assert share("mgrao-5:1") == 1.0 - 0.4 * 5 * (2 * n + 1) / by_max
    assert share("mgrao-1:1") == 1.0 - 0.4 * (2 * n + 1) / by_max
    assert share("mgrao-adaptive:5") == 1.0 - 0.4 * (5 * (2 * n + 1) + 6 * parents) / by_max
    assert share("independent-q") == 1.0 - 0.4 * n / by_max
    assert share("bandit") == 1.0 - 0.4 * (n + 2) / by_max
    assert share("uniform") == share("oracle") == 1.0
    assert share("mgrao-1:1") > share("mgrao-5:1") > share("mgrao-25:1") > share("mgrao-max")
    full = make_params({"learning_cost": 1.0}, base=params)
    assert task_share(parse_algorithm("mgrao-max", parents), full) == 0.0  # all of it, and never below
    assert eq.task_share(1.0, 2 * by_max, by_max) == 0.0
    resources = make_params({"learning_cost": 0.4, "n_resources": 3}, base=params)  # a PW per resource: the
    assert task_share(parse_algorithm("mgrao-5:1", parents), resources) == share("mgrao-5:1")  # same share


@pytest.mark.parametrize(("value", "text"), [(-0.1, "in [0, 1]"), (1.5, "in [0, 1]"), ("much", "number"),
                                             (float("nan"), "finite")])
def test_a_bad_cost_is_refused_naming_the_field_and_its_limit(value, text):
    with pytest.raises(ConfigError) as info:
        make_params({"learning_cost": value})
    assert info.value.field == "learning_cost" and text in info.value.message


def test_a_learner_that_does_not_say_what_it_keeps_runs_only_without_a_cost(monkeypatch):
    # a learner registered without learned_numbers (the base's, which refuses for a learner): refused when the
    # experiment is made, naming the field, not later in a worker; at no cost it runs as before
    monkeypatch.setattr(type(FAMILIES_BY_NAME["bandit"]), "learned_numbers", Family.learned_numbers)
    with pytest.raises(ConfigError) as info:
        make_spec("single", ["uniform", "bandit"], seeds=2, episodes=5, overrides={"learning_cost": 0.1})
    assert info.value.field == "learning_cost" and "bandit does not declare" in info.value.message
    assert run_experiment(make_spec("single", ["uniform", "bandit"], seeds=2, episodes=5)).runs
    make_spec("single", ["uniform", "oracle"], seeds=2, episodes=5, overrides={"learning_cost": 0.1})  # no learner


def test_a_cost_is_every_learners_own_so_a_cost_sweep_pairs_seed_by_seed():
    free = {"system": "large", "episodes": 100, "params": {}}
    costly = {"system": "large", "episodes": 100, "params": {"learning_cost": 0.25}}
    assert world_digest(free) == world_digest(costly)  # one world: every algorithm of a seed faces the same draws
    assert own_values("mgrao-max", costly)["learning_cost"] == 0.25 and own_values("mgrao-max", free)[
        "learning_cost"] == 0.0  # two configurations of it
    for label in ("mgrao-adaptive:5", "independent-q", "bandit"):
        assert "learning_cost" in own_values(label, costly)
    assert own_values("uniform", costly) == own_values("oracle", costly) == {}


def test_the_environments_price_a_cost_with_the_numbers_the_learner_declares():
    # they refused any learning_cost (issue 44, item 4); now the caller declares what its learner keeps, and a
    # built-in family's declared numbers give the engine's utilities (tests/core/test_vector_env.py)
    for make in (parallel_env, vector_env):
        with pytest.raises(ConfigError) as info:
            make("single", learning_cost=0.2)
        assert info.value.field == "learned_numbers" and "must be declared under a learning_cost" in info.value.message
        for bad in (-1, 1.5, True, [1, 2], "10", [[1, 2]], [None]):
            with pytest.raises(ConfigError) as info:
                make("single", learning_cost=0.2, learned_numbers=bad)
            assert info.value.field == "learned_numbers" and "whole number" in info.value.message
    assert parallel_env("single", learning_cost=0.0).params.learning_cost == 0.0
    params = make_params({"learning_cost": 0.4}, base=PRESETS["multi"].params)
    most = learned_by_max(params)  # mgrao-max's: 10 * (2 * 20 + 1)
    env = vector_env("multi", seeds=[0, 1], learning_cost=0.4, learned_numbers=[0, 41, most])
    shares = [1.0, eq.task_share(0.4, 41, most), 0.6]
    assert env.task_share.tolist() == [shares, shares] and env.learned_numbers.tolist() == [[0, 41, most]] * 2
    env.learned_numbers = [[most, most, most], [0, 0, 1]]  # one per world and child, from the next episode on
    assert env.task_share.tolist() == [[0.6] * 3, [1.0, 1.0, eq.task_share(0.4, 1, most)]]
    single = parallel_env("multi", learning_cost=0.4, learned_numbers=41)
    assert single.learned_numbers.tolist() == [41] * 3 and single._vector.task_share.tolist() == [[shares[1]] * 3]
    with pytest.raises(ConfigError) as info:
        env.learned_numbers = None
    assert info.value.field == "learned_numbers"


def test_chunks_blocks_and_threads_change_no_number_under_a_cost():
    spec = make_spec("multi", ALGORITHMS, seeds=[0, 1, 2], episodes=15, overrides={"learning_cost": 0.7})
    whole = _numbers(run_experiment(spec))
    assert _numbers(run_experiment(spec, episodes_per_block=4)) == whole
    assert _numbers(run_experiment(spec, memory_budget=1)) == whole
    one = _numbers(run_experiment(make_spec("multi", ALGORITHMS[2:4], seeds=[2], episodes=15,
                                            overrides={"learning_cost": 0.7})))
    assert one == [n for n in whole if n[0] in ALGORITHMS[2:4] and n[1] == 2]  # other lanes beside it change nothing
    assert np.isfinite([r.utilities for r in run_experiment(spec).runs]).all()
