"""The batched numba engine equals the dense per-agent reference built from the equations."""

import itertools

import numpy as np
import pytest

from mgrao_core import make_spec, reference, run_experiment
from mgrao_core.algorithms import LEARNERS
from mgrao_core.algorithms.mgrao import compiled
from mgrao_core.engine.environment import choose_child, environment_of
from mgrao_core.params import ABSENT_TASKS, QUALITY_MODELS, ROUTINGS, make_params

from ._helpers import assert_matches_reference

CASES = [
    ("single", {}, None, [0, 7]),
    ("multi", {}, None, [0, 7]),
    ("volatile", {}, None, [0, 7]),
    ("volatile", {"rejoin_profile": "new"}, None, [1, 2]),
    ("multi", {"tie_break": "first", "initial_estimate": 0}, None, [0, 5]),
    ("multi", {"tie_break": "first"}, None, [3]),
    ("single", {"trace_decay": 0.5}, None, [0, 4]),
    ("single", {"trace_decay": 0.99}, None, [0, 4]),
    ("single", {"trace_decay": 0.999, "learning_rate": 1.0}, None, [2]),
    ("single", {"temperature": 1}, None, [0, 4]),
    ("single", {}, ["oracle", "uniform", "mgrao-2:1", "mgrao-5:1"], [0, 9]),
    ("multi", {"epsilon": 0.5, "boltzmann_temperature": 2.0}, ["oracle", "mgrao-5:1"], [6]),
    ("large", {}, None, [3]),
    ("large", {"quality_model": "relative-linear", "routing": "per-task"}, None, [1]),
    ("multi", {"quality_model": "relative-linear", "routing": "per-task"}, None, [0, 7]),
    ("single", {"quality_model": "exponential", "half_saturation": 0.05}, None, [2]),
    ("multi", {"n_children": 5, "epsilon": 0.3, "initial_estimate": 0.0}, None, [4]),
]

READINGS = list(itertools.product(QUALITY_MODELS, ROUTINGS, (False, True), ABSENT_TASKS))


@pytest.mark.parametrize(("quality_model", "routing", "load_sharing", "absent_tasks"), READINGS,
                         ids=["-".join(map(str, r)) for r in READINGS])
def test_engine_equals_reference_under_every_reading(quality_model, routing, load_sharing, absent_tasks):
    # several children (routing matters), volatility (absent tasks matter), every kind of lane
    overrides = {"quality_model": quality_model, "routing": routing, "load_sharing": load_sharing,
                 "absent_tasks": absent_tasks, "leave_probability": 0.25, "join_probability": 0.25}
    spec = make_spec("multi", ["uniform", "oracle", "mgrao-1:1", "mgrao-2:1", "mgrao-max"], seeds=[0, 5],
                     episodes=25, overrides=overrides)
    assert_matches_reference(run_experiment(spec), atol=1e-12)


@pytest.mark.parametrize(("system", "overrides", "algorithms", "seeds"), CASES,
                         ids=[f"{c[0]}-{c[1]}-{c[2]}" for c in CASES])
def test_engine_equals_reference(system, overrides, algorithms, seeds):
    spec = make_spec(system, algorithms, seeds=seeds, episodes=30, overrides=overrides)
    assert_matches_reference(run_experiment(spec))


def test_engine_equals_reference_on_long_run_with_many_rebases():
    # 200 episodes x 10 parents x 5 tasks = 10,000 updates: many lazy rebases, scale underflow guard
    spec = make_spec("single", ["mgrao-1:1", "mgrao-max"], seeds=[11], episodes=200,
                     overrides={"learning_rate": 1.0})
    assert_matches_reference(run_experiment(spec))


def test_engine_equals_reference_when_blocks_are_small():
    spec = make_spec("multi", seeds=[2], episodes=20)
    result = run_experiment(spec, episodes_per_block=3)
    assert_matches_reference(result)


def test_rebase_interval():
    # 0.9 ** -k <= 64  <=>  k <= ln 64 / -ln 0.9 = 39.47
    assert compiled.rebase_interval(0.9) == 39
    assert compiled.rebase_interval(0.5) == 6  # 2 ** 6 = 64
    assert compiled.rebase_interval(0.001) == 1
    assert 0.99 ** -compiled.rebase_interval(0.99) <= compiled.TRACE_SCALE_LIMIT


def test_choose_child_kernel_equals_reference():
    rng = np.random.default_rng(5)
    for tie_break in ("random", "first"):
        params = make_params({"n_children": 4, "epsilon": 0.3, "boltzmann_temperature": 0.2,
                              "tie_break": tie_break})
        for _ in range(300):
            estimates = rng.choice([0.1, 0.5, 0.5, 0.9], size=4)
            u = rng.random(3)
            expected = reference.choose_child(estimates, u, params)
            assert choose_child(estimates, u, environment_of(params)) == expected


def test_result_shapes():
    spec = make_spec("multi", ["uniform", "mgrao-2:1", "mgrao-max"], seeds=[4, 1], episodes=6)
    result = run_experiment(spec)
    assert [(r.algorithm, r.seed) for r in result.runs] == [
        ("uniform", 4), ("uniform", 1), ("mgrao-2:1", 4), ("mgrao-2:1", 1), ("mgrao-max", 4), ("mgrao-max", 1)
    ]
    by = {(r.algorithm, r.seed): r for r in result.runs}
    assert by[("uniform", 4)].group_weights.shape == (3, 0, 20)
    assert by[("mgrao-2:1", 4)].group_weights.shape == (3, 2, 20)
    assert by[("mgrao-max", 1)].group_weights.shape == (3, 10, 20)
    assert by[("mgrao-max", 1)].combined_weights.shape == (3, 20)
    assert result.utilities("mgrao-2:1").shape == (2, 6)
    np.testing.assert_array_equal(by[("uniform", 1)].combined_weights, np.full((3, 20), 0.05))


def test_quality_codes_cover_the_schema():
    from mgrao_core.quality import QUALITY_MODELS as REGISTERED

    assert set(REGISTERED) == set(QUALITY_MODELS)
    assert len({model.code for model in REGISTERED.values()}) == len(QUALITY_MODELS)


def test_compiled_estimates_per_composite_keep_one_running_mean_of_taq_per_child():
    from mgrao_core.engine.environment import update_estimates

    estimates = np.full((1, 3), 1.0)
    tries = np.zeros((1, 3), dtype=np.int64)
    child_of = np.full(5, 2, dtype=np.int64)
    values = np.full(5, 0.06)
    update_estimates(estimates, tries, child_of, values, 0.3, True)
    update_estimates(estimates, tries, child_of, values * 2, 0.5, True)
    np.testing.assert_allclose(estimates[0], [1.0, 1.0, 0.4])  # the first return replaces the start
    assert tries[0].tolist() == [0, 0, 2]
    # per task: one running mean per (atomic task, child) of the absolute value
    estimates = np.full((5, 3), 1.0)
    tries = np.zeros((5, 3), dtype=np.int64)
    child_of = np.array([0, 1, 2, 0, 1])
    update_estimates(estimates, tries, child_of, np.arange(5.0), 0.9, False)
    assert [estimates[k, child_of[k]] for k in range(5)] == [0.0, 1.0, 2.0, 3.0, 4.0]
    assert tries.sum() == 5



def test_the_kernel_is_compiled_for_the_families_a_job_runs(monkeypatch):
    # a family with no lane, and several resources of a one-resource system, reach the kernel as None, so numba
    # compiles (and caches) a kernel without their code: the paper's configurations compile in a third of the time.
    # What a chunk's own combination is, as the runner asks for it (where the kernel of every family is cached and
    # the chunk's own is not, the chunk runs on that one, with the same numbers: tests/core/test_compiling.py).
    from numba import types

    from mgrao_core import runner

    ready = runner.ready_kernel
    calls = []
    monkeypatch.setattr(runner, "ready_kernel",
                        lambda spec, arrays, head, finish_head, learners, *rest: calls.append(
                            (head, finish_head, learners)) or ready(spec, arrays, head, finish_head, learners, *rest))

    def nones(algorithms, overrides=None):
        calls.clear()
        run_experiment(make_spec("single", algorithms, seeds=1, episodes=2, overrides=overrides))
        head, _, learners = calls[0]
        several, links, outside, failing = head[2], head[3], head[7], head[8]
        assert links is None  # a complete world: no links drawn, the sparse code not compiled
        assert outside is None  # a run has no environment outside it (mgrao_core.env's steps do)
        assert failing is None  # no task can fail (task_need 0)
        return [several is None] + [lanes is None for lanes in learners]

    assert nones(["uniform", "mgrao-1:1", "mgrao-max"]) == [True, False, True, True, True, True]
    assert nones(["uniform", "independent-q", "bandit"]) == [True, True, True, False, False, True]
    assert nones(["mgrao-max", "mgrao-adaptive:2", "independent-q", "bandit"], {"n_resources": 2}) == [
        False, False, False, False, False, True]
    assert nones(["uniform"]) == [True, True, True, True, True, True]
    # and the kernel it compiles for uniform alone has no learner's code, several resources, observations, tasks
    # that fail or links of a sparse world: every optional argument is None in its types
    own, _ = runner._kernel_types(*calls[0])
    assert sum(isinstance(t, types.NoneType) for t in own) == 4 + len(LEARNERS)
