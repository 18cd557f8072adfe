"""Atomic tasks that fail, and hierarchical allocation (issue 33, item 2): the engine against the dense reference,
the counts and rates, defaults, determinism and bad values."""

import numpy as np
import pytest

from mgrao_core import ConfigError, TaskCounts, make_params, make_spec, reference, run_experiment
from mgrao_core.equations import n_neighbours, need_amount, neighbour
from tests.core._helpers import assert_matches_reference, assert_resources_match_reference

ALGORITHMS = ["uniform", "mgrao-1:1", "mgrao-max", "oracle"]  # one kernel signature for every test with one resource
BORROW = {"task_need": 1.5, "hierarchy": "borrow"}

CASES = [
    {"task_need": 1.5},
    BORROW,
    {"task_need": 1.5, "hierarchy": "hand-over", "neighbours": "ring", "handover_cost": 0.3},
    {"task_need": 1.2, "hierarchy": "borrow", "load_sharing": True, "routing": "per-task", "neighbours": "ring"},
    {"task_need": 1.2, "hierarchy": "hand-over", "quality_model": "relative-linear", "learning_cost": 0.1,
     "n_children": 5},
    {"task_need": 0.8, "hierarchy": "hand-over", "quality_model": "exponential", "leave_probability": 0.2,
     "join_probability": 0.5, "absent_tasks": "counted"},
]
RESOURCE_CASES = [
    {"n_resources": 2, "n_children": 4, "task_need": 1.0, "hierarchy": "hand-over"},
    {"n_resources": 3, "n_children": 4, "task_need": 1.0, "hierarchy": "borrow", "resource_combination": "weighted",
     "resource_credit": "by-share", "neighbours": "ring", "load_sharing": True},
]


@pytest.mark.parametrize("overrides", CASES, ids=[str(c) for c in CASES])
def test_engine_equals_reference(overrides):
    result = run_experiment(make_spec("multi", ALGORITHMS, seeds=[0, 3], episodes=25, overrides=overrides))
    assert_matches_reference(result, atol=1e-12)  # and what became of the tasks, exactly
    assert sum(run.tasks.failed for run in result.runs) > 0  # the case makes tasks fail
    if overrides.get("hierarchy", "none") != "none":
        assert sum(run.tasks.handed_over for run in result.runs) > 0  # and the hierarchy completes some


@pytest.mark.parametrize("overrides", RESOURCE_CASES, ids=[str(c) for c in RESOURCE_CASES])
def test_engine_equals_reference_with_several_resources(overrides):
    result = run_experiment(make_spec("multi", ALGORITHMS, seeds=[0, 3], episodes=25, overrides=overrides))
    assert_resources_match_reference(result, atol=1e-12)
    assert sum(run.tasks.failed for run in result.runs) > 0
    assert sum(run.tasks.handed_over for run in result.runs) > 0


def test_counts_and_rates():
    result = run_experiment(make_spec("multi", ALGORITHMS, seeds=[0, 3], episodes=20, overrides=BORROW))
    p = result.spec.params
    for run in result.runs:  # every composite task arrives (multi is static): each of its atomic tasks is counted
        assert run.tasks.allocated == 20 * p.n_parents * p.types_per_composite
        assert 0 <= run.tasks.failed + run.tasks.handed_over <= run.tasks.allocated
    pooled = result.task_counts()
    assert set(pooled) == set(ALGORITHMS)
    for algorithm, counts in pooled.items():
        runs = [r.tasks for r in result.runs if r.algorithm == algorithm]
        assert counts == runs[0] + runs[1]
        assert counts.failure_rate == counts.failed / counts.allocated and 0 <= counts.failure_rate <= 1
        assert counts.rates() == {"failure_rate": counts.failure_rate, "handover_rate": counts.handover_rate}
    assert TaskCounts().rates() == {"failure_rate": 0.0, "handover_rate": 0.0}  # nothing can fail: 0, not null


def test_a_task_that_gets_its_need_never_fails_and_one_child_has_no_neighbour():
    # single has one child: it has nobody to turn to, and the uniform split fails exactly where a type's amount,
    # resource / capability / n_types, is below the need (every episode, every parent)
    params = make_params({"task_need": 0.9, "hierarchy": "hand-over", "capability_spread": 0.5},
                         base=make_spec("single", ["uniform"], seeds=1).params)
    spec = make_spec("single", ["uniform"], seeds=[2], episodes=5, overrides=params.as_config())
    (run,) = run_experiment(spec).runs
    world = reference.SeedEnvironment(params, 2).world
    amounts = world.type_resources_single[0] / params.n_types
    short = amounts < need_amount(params.task_need, params.resource_mean, params.n_types)
    assert 0 < short.sum() < params.n_types  # some types fail, some do not
    expected = 5 * sum(int(short[t]) for t in world.parent_types.ravel())
    assert run.tasks == TaskCounts(5 * world.parent_types.size, expected, 0)
    small = make_spec("single", ["uniform"], seeds=[2], episodes=5, overrides={"task_need": 1e-9})
    assert run_experiment(small).runs[0].tasks == TaskCounts(5 * world.parent_types.size, 0, 0)


def test_neighbours():
    assert [neighbour(1, i, 4, False) for i in range(n_neighbours(4, False))] == [2, 3, 0]
    assert [neighbour(0, i, 4, True) for i in range(n_neighbours(4, True))] == [1, 3]
    assert n_neighbours(2, True) == 1 and n_neighbours(1, True) == n_neighbours(1, False) == 0


def test_defaults_and_a_hierarchy_without_a_need_are_todays_numbers_bit_for_bit():
    # (the golden runs check the paper's systems; here: hierarchy and neighbours change nothing while no task fails)
    today = run_experiment(make_spec("multi", ALGORITHMS, seeds=[1], episodes=15))
    idle = run_experiment(make_spec("multi", ALGORITHMS, seeds=[1], episodes=15,
                                    overrides={"hierarchy": "borrow", "neighbours": "ring", "handover_cost": 0.9}))
    for a, b in zip(today.runs, idle.runs, strict=True):
        assert np.array_equal(a.utilities, b.utilities) and np.array_equal(a.combined_weights, b.combined_weights)
        assert a.tasks == b.tasks == TaskCounts()


def test_same_numbers_however_the_work_is_split():
    spec = make_spec("multi", ALGORITHMS, seeds=[4, 1, 9], episodes=20, overrides=BORROW)
    whole = {(r.algorithm, r.seed): r for r in run_experiment(spec).runs}
    for split in (run_experiment(spec, memory_budget=1), run_experiment(spec, episodes_per_block=3),
                  run_experiment(make_spec("multi", ALGORITHMS[::-1], seeds=[9], episodes=20, overrides=BORROW))):
        for run in split.runs:
            same = whole[(run.algorithm, run.seed)]
            assert np.array_equal(run.utilities, same.utilities) and run.tasks == same.tasks


def test_the_hierarchy_completes_what_would_fail():
    # uniform's allocation is fixed, and with one composite per parent routed by estimates the routes can differ;
    # pooled over seeds, each kind of hierarchy leaves fewer tasks failed and a higher utility than none
    def run(overrides):
        result = run_experiment(make_spec("multi", ["uniform"], seeds=[0, 1, 2, 4], episodes=20,
                                          overrides={"task_need": 1.5, **overrides}))
        return result.task_counts()["uniform"], result.utilities("uniform").mean()

    none, borrow, hand_over = run({}), run({"hierarchy": "borrow"}), run({"hierarchy": "hand-over"})
    assert borrow[0].failure_rate < none[0].failure_rate and hand_over[0].failure_rate < none[0].failure_rate
    assert borrow[1] > none[1] and hand_over[1] > none[1]
    assert run({"hierarchy": "hand-over", "handover_cost": 1.0})[1] <= hand_over[1]  # a hand-over that gives nothing


@pytest.mark.parametrize(("field", "value", "limit"), [
    ("task_need", -0.1, "0"), ("task_need", 11.0, "10"), ("task_need", float("nan"), "finite"),
    ("hierarchy", "share", "borrow"), ("neighbours", "grid", "ring"), ("handover_cost", 1.5, "1"),
])
def test_bad_values_are_refused_naming_the_field(field, value, limit):
    with pytest.raises(ConfigError) as info:
        make_spec("multi", ["uniform"], seeds=1, overrides={field: value})
    assert info.value.field == field and limit in info.value.message
