"""mgrao-adaptive:x: its labels, its compiled steps against its dense reference step, determinism."""

import numpy as np
import pytest

from mgrao_core import ConfigError, get_preset, make_spec, parse_algorithm, reference, run_experiment
from mgrao_core.algorithms import FAMILIES_BY_NAME, describe_label, sort_key
from mgrao_core.algorithms.adaptive import SNAPSHOTS
from tests.core._helpers import assert_matches_reference

FAMILY = FAMILIES_BY_NAME["mgrao-adaptive"]


def test_labels_allow_any_x_up_to_n_parents():
    assert parse_algorithm(" MGRAO-ADAPTIVE:05", 10).label == "mgrao-adaptive:5"
    alg = parse_algorithm("mgrao-adaptive:3", 10)  # 3 does not divide 10
    assert (alg.kind, alg.n_groups) == ("mgrao-adaptive", 3)
    for bad in ("mgrao-adaptive:0", "mgrao-adaptive:11"):
        with pytest.raises(ConfigError) as info:
            parse_algorithm(bad, 10, "algorithms[0]")
        assert info.value.field == "algorithms[0]" and "n_parents = 10" in info.value.message
    assert describe_label("mgrao-adaptive:7")["groups"] == 7
    assert FAMILY.examples(50) == ["mgrao-adaptive:2", "mgrao-adaptive:5", "mgrao-adaptive:10"]
    assert FAMILY.forms(10)[0]["valid"] == list(range(1, 11))
    labels = ["mgrao-adaptive:5", "oracle", "mgrao-max", "mgrao-adaptive:2", "mgrao-5:1", "uniform"]
    assert sorted(labels, key=sort_key) == ["uniform", "mgrao-5:1", "mgrao-max", "mgrao-adaptive:2",
                                            "mgrao-adaptive:5", "oracle"]


def test_memory_stays_near_fixed_groups_and_far_below_max():
    params = get_preset("large").params
    adaptive = FAMILY.memory_per_child(parse_algorithm("mgrao-adaptive:5", 50), params)
    fixed = FAMILIES_BY_NAME["mgrao"].memory_per_child(parse_algorithm("mgrao-5:1", 50), params)
    most = FAMILIES_BY_NAME["mgrao"].memory_per_child(parse_algorithm("mgrao-max", 50), params)
    assert adaptive - fixed == 6 * 8 * params.n_parents + 9 * params.n_parents + 8  # six numbers per parent, an
    # episode count, and a count and a flag per parent (the first x used as rows' while regrouping)
    assert adaptive < most / 3


def _check_memberships(result):
    """Each run's recorded memberships are the reference's (every ``every // regroup_every``-th of them)."""
    spec = result.spec
    for run in result.runs:
        if run.membership is None:
            continue
        _, children = reference.simulate(spec.params, run.algorithm, run.seed, spec.episodes)
        step = run.membership_every // spec.params.regroup_every
        for c, child in enumerate(children):
            expected = np.stack(child.history[::step])[: run.membership.shape[1]]
            assert run.membership.shape[1] == min(len(child.history[::step]), SNAPSHOTS)
            np.testing.assert_array_equal(run.membership[c], expected, err_msg=f"{run.algorithm} seed {run.seed}")


# mgrao-1:1 beside each: the kernel signature of MG-RAO and adaptive lanes, which other tests compile anyway
@pytest.mark.parametrize(("system", "algorithms", "seeds", "episodes", "overrides"), [
    ("single", ["mgrao-1:1", "mgrao-adaptive:2", "mgrao-adaptive:3"], [0, 7], 40, {"regroup_every": 5}),
    ("multi", ["mgrao-1:1", "mgrao-adaptive:2"], [1], 30, {"regroup_every": 4}),
    ("multi", ["mgrao-1:1", "mgrao-adaptive:5"], [2], 30, {"regroup_every": 3, "routing": "per-task"}),
    ("volatile", ["mgrao-1:1", "mgrao-adaptive:5"], [3, 4], 40, {"regroup_every": 5}),
    ("large", ["mgrao-1:1", "mgrao-adaptive:5", "mgrao-adaptive:7"], [5], 30, {}),
    ("large", ["mgrao-1:1", "mgrao-adaptive:10"], [6], 30, {"regroup_by": "types"}),
    ("single", ["mgrao-1:1", "mgrao-adaptive:4"], [8], 30, {"regroup_by": "types", "regroup_every": 2}),
])
def test_engine_matches_the_dense_reference(system, algorithms, seeds, episodes, overrides):
    result = run_experiment(make_spec(system, algorithms, seeds=seeds, episodes=episodes, overrides=overrides))
    assert_matches_reference(result)
    _check_memberships(result)
    assert any((run.membership[:, 1:] != run.membership[:, :1]).any()  # groups changed
               for run in result.runs if run.membership is not None)


def test_the_history_halves_when_full():
    result = run_experiment(make_spec("single", ["mgrao-adaptive:3", "mgrao-1:1"], seeds=[0], episodes=80,
                                      overrides={"regroup_every": 1}))
    run = result.runs[0]
    assert run.membership_every == 4 and run.membership.shape == (1, 20, 10)  # 80 regroups: every 4th of them
    _check_memberships(result)


def test_without_a_regroup_it_is_fixed_mgrao_bit_for_bit():
    spec = make_spec("large", ["mgrao-5:1", "mgrao-adaptive:5"], seeds=[0, 1], episodes=25,
                     overrides={"regroup_every": 1000})
    by = {(r.algorithm, r.seed): r for r in run_experiment(spec).runs}
    for seed in (0, 1):
        fixed, adaptive = by[("mgrao-5:1", seed)], by[("mgrao-adaptive:5", seed)]
        assert fixed.utilities.tobytes() == adaptive.utilities.tobytes()
        assert fixed.group_weights.tobytes() == adaptive.group_weights.tobytes()
        assert fixed.combined_weights.tobytes() == adaptive.combined_weights.tobytes()
        assert adaptive.membership.shape == (1, 1, 50)


def _by_run(result):
    return {(r.algorithm, r.seed): (r.utilities.tobytes(), r.group_weights.tobytes(),
                                    b"" if r.membership is None else r.membership.tobytes()) for r in result.runs}


def test_deterministic_whatever_runs_beside_it_and_whatever_the_blocks():
    labels = ["mgrao-adaptive:5", "mgrao-adaptive:3", "mgrao-2:1"]  # with MG-RAO: the signature of the tests above
    overrides = {"regroup_every": 3}
    spec = make_spec("volatile", labels, seeds=[4, 1, 9], episodes=22, overrides=overrides)
    whole = _by_run(run_experiment(spec))
    assert whole == _by_run(run_experiment(spec))
    assert whole == _by_run(run_experiment(spec, episodes_per_block=5))
    reordered = _by_run(run_experiment(make_spec("volatile", labels[::-1], seeds=[9, 1, 4], episodes=22,
                                                 overrides=overrides)))
    assert whole == reordered
    beside = ["mgrao-adaptive:3", "mgrao-balance"]  # no MG-RAO lanes: one kernel for both tests
    alone = _by_run(run_experiment(make_spec("volatile", beside, seeds=[1], episodes=22,
                                             overrides=overrides)))
    assert alone[("mgrao-adaptive:3", 1)] == whole[("mgrao-adaptive:3", 1)]
