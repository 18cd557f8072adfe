"""``group_blend``: algorithm 2's blend with (the paper's default) or without the sample counts.

The engine against the dense reference (1e-12) under ``dkl-only``, the default unchanged bit for bit,
the equations themselves, the configuration's identity, and bad input.
"""

import numpy as np
import pytest

from mgrao_core import ConfigError, make_params, make_spec, run_experiment
from mgrao_core import equations as eq
from mgrao_core.params import PARAMETERS_BY_NAME

from ._helpers import assert_matches_reference

ALGORITHMS = ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max", "mgrao-adaptive:5"]


@pytest.mark.parametrize(("system", "overrides"), [
    ("bursty", {}),
    ("drift", {"schedule": [{"episode": 8, "change": "new-profiles", "fraction": 0.3}]}),
    ("multi", {"routing": "per-task"}),
    ("volatile", {"frequency_profile": "two-speed"}),
])
def test_dkl_only_engine_equals_reference(system, overrides):
    algorithms = [a for a in ALGORITHMS if system in ("bursty", "large") or a != "mgrao-5:1"]
    spec = make_spec(system, algorithms, seeds=[0, 7], episodes=20, overrides={**overrides, "group_blend": "dkl-only"})
    assert_matches_reference(run_experiment(spec), atol=1e-12)


def test_bounded_dkl_only_equals_reference():
    # more than MIN_BOUNDED_GROUPS groups: the bounded lazy update
    overrides = {"n_parents": 80, "types_per_composite": 3, "frequency_profile": "two-speed",
                 "group_blend": "dkl-only"}
    spec = make_spec("single", ["mgrao-max"], seeds=[3], episodes=15, overrides=overrides)
    assert_matches_reference(run_experiment(spec))


def test_default_is_the_papers_blend_bit_for_bit():
    assert PARAMETERS_BY_NAME["group_blend"].default == "dkl-and-count"
    assert PARAMETERS_BY_NAME["group_blend"].identity == "when-set"
    algorithms = ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max"]
    plain = run_experiment(make_spec("bursty", algorithms, seeds=[1, 2], episodes=15))
    named = run_experiment(make_spec("bursty", algorithms, seeds=[1, 2], episodes=15,
                                     overrides={"group_blend": "dkl-and-count"}))
    dkl_only = run_experiment(make_spec("bursty", algorithms, seeds=[1, 2], episodes=15,
                                        overrides={"group_blend": "dkl-only"}))
    for a in algorithms:
        assert np.array_equal(plain.utilities(a), named.utilities(a))
    assert np.array_equal(plain.utilities("uniform"), dkl_only.utilities("uniform"))
    assert np.array_equal(plain.utilities("mgrao-1:1"), dkl_only.utilities("mgrao-1:1"))  # one group: B is moot
    assert not np.array_equal(plain.utilities("mgrao-5:1"), dkl_only.utilities("mgrao-5:1"))
    assert make_params({}).as_config() == make_params({"group_blend": "dkl-and-count"}).as_config()
    assert "group_blend" in make_params({"group_blend": "dkl-only"}).as_config()


def test_blend_equations():
    pw = np.array([[0.25, 0.25, 0.25, 0.25], [0.7, 0.1, 0.1, 0.1], [0.4, 0.4, 0.1, 0.1]])
    counts = np.array([10.0, 0.0, 30.0])
    dkl = eq.kl_to_uniform(pw)
    np.testing.assert_allclose(eq.blend_vector(pw, counts), dkl / dkl.sum() + counts / counts.sum())
    np.testing.assert_allclose(eq.blend_vector(pw, counts, use_counts=False), dkl / dkl.sum())
    # all rows uniform: sumnorm of zero divergences is uniform, with or without counts
    np.testing.assert_allclose(eq.blend_vector(np.full((3, 4), 0.25), counts, use_counts=False), np.full(3, 1 / 3))


@pytest.mark.parametrize("value", ["dkl", "count-only", "", 1, None])
def test_bad_group_blend_names_the_field_and_the_choices(value):
    with pytest.raises(ConfigError) as error:
        make_params({"group_blend": value})
    assert error.value.field == "group_blend"
    message = str(error.value)
    assert "must not be empty" in message if value is None else ("dkl-and-count" in message and "dkl-only" in message)
