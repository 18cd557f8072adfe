"""Active rows: an update visits only the rows whose trace can still change them in float64.

A row's trace is dropped once everything it can still add, over all later updates, is below half
a unit in the last place of every weight it adds to (``algorithms.mgrao.compiled.trace_is_negligible``), and
the row then leaves its child's active rows until a value of its group comes back. Children with
more than ``MIN_BOUNDED_GROUPS`` groups do that; the fixture ``every_child_bounded`` makes every
child do it, so that the small systems of every reading cover it too. Whatever the system, reading
and configuration, the engine must still equal the dense literal algorithm 1
(:mod:`mgrao_core.reference`) to 1e-12 in utilities and final weights.
"""

import itertools
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from mgrao_core import engine, make_spec, run_experiment
from mgrao_core import equations as eq
from mgrao_core.algorithms.mgrao import family as learning_module
from mgrao_core.algorithms.mgrao.compiled import NEGLIGIBLE, trace_is_negligible, trace_tail
from mgrao_core.params import ABSENT_TASKS, QUALITY_MODELS, ROUTINGS

from ._helpers import assert_matches_reference


@pytest.fixture
def every_child_bounded(monkeypatch):
    """Every child drops negligible traces, however few its groups."""
    monkeypatch.setattr(learning_module, "MIN_BOUNDED_GROUPS", 0)


@pytest.fixture
def final_lanes(monkeypatch):
    """The lanes of every chunk as the engine leaves them (after the last episode)."""
    seen = []
    finish = engine.finish

    def keep(lanes, several, mgrao_lanes, *other_learners):
        finish(lanes, several, mgrao_lanes, *other_learners)
        seen.append(SimpleNamespace(groups=lanes.groups, n_rows=mgrao_lanes.n_rows, slot=mgrao_lanes.slot,
                                    counts=mgrao_lanes.counts))

    monkeypatch.setattr(engine, "finish", keep)
    return seen


def dropped_rows(lanes_list) -> int:
    """Rows that received values but are inactive at the end: their trace was dropped."""
    return sum(int(((lanes.slot < 0) & (lanes.counts > 0)).sum()) for lanes in lanes_list)


MANY_GROUPS = [
    ("single", ["mgrao-max", "mgrao-100:1", "mgrao-20:1"], [0, 1], 30, {"n_parents": 100}),
    ("multi", ["mgrao-max", "mgrao-1:1"], [0, 3], 30,
     {"n_parents": 100, "quality_model": "relative-linear", "routing": "per-task"}),
    ("multi", ["mgrao-max"], [2], 30, {"n_parents": 100, "n_children": 5, "epsilon": 0.3}),
    ("volatile", ["mgrao-max", "mgrao-50:1"], [0, 1], 40, {"n_parents": 100, "rejoin_profile": "new"}),
    ("volatile", ["mgrao-max"], [4], 40, {"n_parents": 100, "absent_tasks": "counted", "load_sharing": True}),
    ("large", ["mgrao-max", "mgrao-150:1"], [3], 20, {"n_parents": 300}),
    # learning rate 1 and a fast decay; learning rate 1 and the slow decay
    ("single", ["mgrao-max"], [5], 30, {"n_parents": 100, "learning_rate": 1.0, "trace_decay": 0.5}),
    ("single", ["mgrao-max"], [6], 40, {"n_parents": 200, "learning_rate": 1.0, "trace_decay": 0.95}),
]


@pytest.mark.parametrize(("system", "algorithms", "seeds", "episodes", "overrides"), MANY_GROUPS,
                         ids=[f"{c[0]}-{c[1][0]}-{c[4]}" for c in MANY_GROUPS])
def test_children_with_many_groups_equal_the_reference(system, algorithms, seeds, episodes, overrides,
                                                       final_lanes):
    overrides = {"n_composite_types": min(overrides["n_parents"], 1000)} | overrides
    spec = make_spec(system, algorithms, seeds=seeds, episodes=episodes, overrides=overrides)
    assert_matches_reference(run_experiment(spec), atol=1e-12)
    assert dropped_rows(final_lanes) > 0  # the bounded update was exercised


@pytest.mark.slow
def test_a_thousand_groups_equal_the_reference(final_lanes):
    spec = make_spec("single", ["mgrao-max"], seeds=[7], episodes=8,
                     overrides={"n_parents": 1000, "n_composite_types": 1000})
    assert_matches_reference(run_experiment(spec), atol=1e-12)
    assert dropped_rows(final_lanes) > 900


READINGS = list(itertools.product(QUALITY_MODELS, ROUTINGS, (False, True), ABSENT_TASKS))


@pytest.mark.parametrize(("quality_model", "routing", "load_sharing", "absent_tasks"), READINGS,
                         ids=["-".join(map(str, r)) for r in READINGS])
def test_every_reading_with_every_child_bounded(quality_model, routing, load_sharing, absent_tasks,
                                                every_child_bounded, final_lanes):
    # a fast decay so that rows of the small system go inactive (and come back) within the run
    overrides = {"quality_model": quality_model, "routing": routing, "load_sharing": load_sharing,
                 "absent_tasks": absent_tasks, "leave_probability": 0.25, "join_probability": 0.25,
                 "trace_decay": 0.5}
    spec = make_spec("multi", ["uniform", "oracle", "mgrao-1:1", "mgrao-2:1", "mgrao-max"], seeds=[0, 5],
                     episodes=40, overrides=overrides)
    assert_matches_reference(run_experiment(spec), atol=1e-12)
    assert dropped_rows(final_lanes) > 0


WORST_CASES = [
    # the slowest decay the schema allows with the largest learning rate: the horizon is about
    # 48,000 updates; parents leaving for good leave their rows idle that long
    ("volatile", {"n_parents": 50, "n_composite_types": 50, "trace_decay": 0.999, "learning_rate": 1.0,
                  "leave_probability": 0.003, "join_probability": 0.0}, 400),
    # tiny weights: many types, a cold softmax, value profiles concentrated on few types (tiny atv)
    ("single", {"n_parents": 100, "n_composite_types": 100, "n_types": 200, "temperature": 0.001,
                "value_concentration": 0.02}, 40),
    ("multi", {"n_parents": 30, "n_composite_types": 30, "n_types": 200, "types_per_composite": 40,
               "temperature": 0.0001, "learning_rate": 1.0, "value_concentration": 0.05,
               "quality_model": "relative-linear", "routing": "per-composite"}, 60),
    # learning rate 1, trace decay 0.99: a horizon of about 4,400 updates, outlasted by absent parents
    ("volatile", {"n_parents": 50, "n_composite_types": 50, "learning_rate": 1.0, "trace_decay": 0.99,
                  "leave_probability": 0.05, "join_probability": 0.05}, 300),
]


@pytest.mark.parametrize(("system", "overrides", "episodes"), WORST_CASES,
                         ids=[f"{c[0]}-{c[1]}" for c in WORST_CASES])
def test_worst_cases_with_every_child_bounded(system, overrides, episodes, every_child_bounded, final_lanes):
    spec = make_spec(system, ["mgrao-max", "mgrao-1:1"], seeds=[1], episodes=episodes, overrides=overrides)
    assert_matches_reference(run_experiment(spec), atol=1e-12)
    assert dropped_rows(final_lanes) > 0


def test_rows_leave_the_active_rows_past_the_horizon(final_lanes):
    # mgrao-max at 300 parents: the 5 values of a parent come back together, then 1,495 others; at
    # the defaults a row stays active for about 400 updates, so about 80 rows are active, not 300
    spec = make_spec("single", ["mgrao-max", "mgrao-10:1"], seeds=[0], episodes=3,
                     overrides={"n_parents": 300, "n_composite_types": 300})
    run_experiment(spec)
    (lanes,) = final_lanes
    max_lane, ten_groups = (0, 1) if lanes.groups[0] == 300 else (1, 0)
    assert 40 < lanes.n_rows[max_lane, 0] < 110
    assert dropped_rows(final_lanes) > 150
    # at most MIN_BOUNDED_GROUPS groups: every row stays active, as before
    assert lanes.n_rows[ten_groups, 0] == 10
    assert (lanes.slot[ten_groups, 0, :10] == np.arange(10)).all()


@settings(max_examples=400, deadline=None)
@given(n=st.integers(2, 200), gamma=st.floats(0.001, 0.999), alpha=st.floats(0.0, 1.0),
       concentration=st.floats(0.005, 10.0), density=st.floats(0.05, 1.0), updates=st.integers(1, 300),
       seed=st.integers(0, 2**32 - 1))
def test_a_negligible_trace_changes_no_bit_of_the_dense_update(n, gamma, alpha, concentration, density, updates,
                                                              seed):
    # The argument of docs/model.md ("The engine"), checked on the dense literal update in float64:
    # while no value of its group comes back, a row with a trace the engine drops evolves exactly,
    # bit for bit, as the same row without the trace.
    rng = np.random.default_rng(seed)
    weights = eq.sumnorm(rng.dirichlet(np.full(n, concentration)))  # tiny weights at a low concentration
    trace = rng.random(n) * (rng.random(n) < density)
    assume(trace.sum() > 0)
    tail = trace_tail(alpha, gamma)
    if tail > 0:  # scale the trace up to the threshold: the largest the engine would drop
        support = trace > 0
        with np.errstate(divide="ignore", over="ignore"):
            trace *= min(NEGLIGIBLE / (tail * trace.sum()),
                         float(np.min(NEGLIGIBLE * weights[support] / (tail * trace[support]))))
        assume(np.isfinite(trace).all())
    assume(trace_is_negligible(weights, trace, float(trace.sum()), tail))
    pw_with = weights[None, :].copy()
    pw_without = weights[None, :].copy()
    e = trace[None, :].copy()
    for _ in range(updates):
        e = np.where(e > 0, e * gamma, 0.0)  # the row's entries of the trace decay
        atv = rng.random()  # at most 1
        pw_with = eq.pw_update(pw_with, e, atv, alpha)
        pw_without = eq.pw_update(pw_without, np.zeros_like(e), atv, alpha)
        assert pw_with.tobytes() == pw_without.tobytes()


def test_trace_is_negligible_against_each_weight():
    tail = trace_tail(0.1, 0.9)  # 0.9
    weights = np.array([0.5, 0.25, 2.0**-40, 0.25 - 2.0**-40])
    trace = np.array([1e-18, 0.0, 0.0, 1e-18])
    assert trace_is_negligible(weights, trace, trace.sum(), tail)
    # the same trace on the tiny weight is not negligible: the horizon grows as the weight shrinks
    assert not trace_is_negligible(weights, trace[[0, 1, 3, 2]], trace.sum(), tail)
    # nor is a trace whose sum could still move the row's sum by half an ulp of 1
    assert not trace_is_negligible(weights, np.array([0.0, 3e-17, 0.0, 0.0]), 3e-17, tail)
    # with a learning rate of 0 nothing is ever added
    assert trace_is_negligible(weights, np.ones(4), 4.0, trace_tail(0.0, 0.9))
