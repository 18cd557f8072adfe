"""The paper's equations on small cases computed by hand."""

import math

import numpy as np
import pytest

from mgrao_core import equations as eq
from mgrao_core.params import make_params


def test_sumnorm_divides_by_the_total():
    # [1, 3] / 4 = [0.25, 0.75]
    np.testing.assert_allclose(eq.sumnorm(np.array([1.0, 3.0])), [0.25, 0.75], rtol=0, atol=1e-15)


def test_sumnorm_of_zeros_is_uniform():
    np.testing.assert_array_equal(eq.sumnorm(np.zeros(4)), [0.25, 0.25, 0.25, 0.25])


def test_sumnorm_rows_independently():
    # row 0: [2, 2] / 4; row 1: zeros -> uniform
    out = eq.sumnorm(np.array([[2.0, 2.0], [0.0, 0.0]]), axis=1)
    np.testing.assert_array_equal(out, [[0.5, 0.5], [0.5, 0.5]])


def test_softmax_with_temperature():
    # softmax([0, ln 3]) = [1, 3] / 4; temperature 0.5 doubles the logits: [1, 9] / 10
    x = np.array([0.0, math.log(3.0)])
    np.testing.assert_allclose(eq.softmax(x), [0.25, 0.75], atol=1e-15)
    np.testing.assert_allclose(eq.softmax(x, 0.5), [0.1, 0.9], atol=1e-15)


def test_softmax_is_stable_for_large_inputs():
    out = eq.softmax(np.array([1000.0, 1000.0]))
    np.testing.assert_array_equal(out, [0.5, 0.5])


def test_eligibility_replaces_with_one_and_decays_positive_entries():
    trace = np.array([[0.0, 0.5], [1.0, 0.0]])
    # (1, 1) becomes 1; 0.5 -> 0.45 and 1.0 -> 0.9; the zero at (0, 0) stays zero
    out = eq.eligibility_update(trace, group=1, task_type=1, decay=0.9)
    np.testing.assert_allclose(out, [[0.0, 0.45], [0.9, 1.0]], atol=1e-15)


def test_eligibility_replaces_rather_than_accumulates():
    trace = np.array([[1.0, 0.0]])
    # the entry was 1 already: replaced by 1, not 1 + 0.9
    out = eq.eligibility_update(trace, group=0, task_type=0, decay=0.9)
    np.testing.assert_array_equal(out, [[1.0, 0.0]])


def test_eligibility_does_not_modify_its_input():
    trace = np.array([[0.5, 0.0]])
    eq.eligibility_update(trace, 0, 1, 0.5)
    np.testing.assert_array_equal(trace, [[0.5, 0.0]])


def test_eligibility_zeros_stay_zero():
    out = eq.eligibility_update(np.zeros((2, 3)), 0, 2, 0.9)
    expected = np.zeros((2, 3))
    expected[0, 2] = 1.0
    np.testing.assert_array_equal(out, expected)


def test_pw_update_adds_and_normalises_rows():
    weights = np.array([[0.5, 0.5], [0.25, 0.75]])
    trace = np.array([[1.0, 0.0], [0.0, 0.5]])
    # row 0: [0.5 + 0.1 * 2 * 1, 0.5] = [0.7, 0.5] / 1.2 = [7/12, 5/12]
    # row 1: [0.25, 0.75 + 0.1 * 2 * 0.5] = [0.25, 0.85] / 1.1 = [0.25/1.1, 0.85/1.1]
    out = eq.pw_update(weights, trace, value=2.0, learning_rate=0.1)
    np.testing.assert_allclose(out, [[7 / 12, 5 / 12], [0.25 / 1.1, 0.85 / 1.1]], atol=1e-15)
    np.testing.assert_allclose(out.sum(axis=1), [1.0, 1.0], atol=1e-15)


def test_pw_update_with_zero_trace_keeps_rows():
    weights = np.array([[0.2, 0.8]])
    np.testing.assert_allclose(eq.pw_update(weights, np.zeros((1, 2)), 5.0, 0.1), weights, atol=1e-15)


def test_kl_to_uniform_is_zero_for_uniform_rows():
    np.testing.assert_allclose(eq.kl_to_uniform(np.full((3, 5), 0.2)), [0.0, 0.0, 0.0], atol=1e-15)


def test_kl_to_uniform_known_values():
    # [1, 0], n = 2: 1 * log(1 * 2) + 0 = log 2
    # [0.75, 0.25]: 0.75 log 1.5 + 0.25 log 0.5 = 0.304099 - 0.173287 = 0.130812
    out = eq.kl_to_uniform(np.array([[1.0, 0.0], [0.75, 0.25]]))
    np.testing.assert_allclose(out, [math.log(2.0), 0.75 * math.log(1.5) + 0.25 * math.log(0.5)], atol=1e-15)
    assert out[1] == pytest.approx(0.130812, abs=1e-6)


def test_kl_to_uniform_is_never_negative():
    # rounding on a nearly uniform row must not give a negative value
    row = np.full((1, 3), 1.0 / 3.0)
    assert eq.kl_to_uniform(row)[0] >= 0.0


def test_blend_vector():
    weights = np.array([[0.5, 0.5], [1.0, 0.0]])
    counts = np.array([1.0, 3.0])
    # dkl = [0, log 2] -> sumnorm [0, 1]; counts -> [0.25, 0.75]; B = [0.25, 1.75]
    np.testing.assert_allclose(eq.blend_vector(weights, counts), [0.25, 1.75], atol=1e-15)


def test_blend_vector_all_zero_is_uniform_plus_uniform():
    # uniform PW rows give dkl = 0 (-> uniform), no counts (-> uniform): [0.5, 0.5] + [0.5, 0.5]
    out = eq.blend_vector(np.full((2, 4), 0.25), np.zeros(2))
    np.testing.assert_allclose(out, [1.0, 1.0], atol=1e-15)


def test_combined_weights_and_temperature():
    weights = np.array([[0.5, 0.5], [1.0, 0.0]])
    counts = np.array([1.0, 3.0])
    # sumnorm(B) = [0.25, 1.75] / 2 = [0.125, 0.875]
    # @ PW = [0.125 * 0.5 + 0.875 * 1, 0.125 * 0.5] = [0.9375, 0.0625]; difference 0.875
    # T = 1: w0 = 1 / (1 + exp(-0.875)) = 0.705785; T = 0.5: 1 / (1 + exp(-1.75)) = 0.851953
    hot = eq.combined_weights(weights, counts, 1.0)
    cold = eq.combined_weights(weights, counts, 0.5)
    np.testing.assert_allclose(hot, [1 / (1 + math.exp(-0.875)), 1 - 1 / (1 + math.exp(-0.875))], atol=1e-15)
    assert hot[0] == pytest.approx(0.705785, abs=1e-6)
    assert cold[0] == pytest.approx(0.851953, abs=1e-6)
    assert cold[0] > hot[0]  # lower temperature is sharper
    assert hot.sum() == pytest.approx(1.0, abs=1e-15)


def test_combined_weights_of_untrained_child_are_uniform():
    out = eq.combined_weights(np.full((3, 4), 0.25), np.zeros(3), 0.25)
    np.testing.assert_allclose(out, np.full(4, 0.25), atol=1e-15)


def _params(**overrides):
    return make_params(overrides)


def test_quality_relative_linear_capped_and_floored():
    # n = 20, q_u = 0.3: q = 6 * share; 0.05 -> 0.3 (the uniform share), 0.025 -> 0.15,
    # 0.1 -> 0.6, 0.2 -> 1.2 capped to 1, 0 -> floor 1e-6; the resource cancels out
    share = np.array([0.05, 0.025, 0.1, 0.2, 0.0])
    params = _params(quality_model="relative-linear")
    for resource in (0.1, 0.5, 1.0):
        out = eq.atomic_quality(share, resource, params)
        np.testing.assert_allclose(out, [0.3, 0.15, 0.6, 1.0, 1e-6], atol=1e-15)


@pytest.mark.parametrize("n_types", [2, 7, 20, 200])
@pytest.mark.parametrize("q_u", [0.1, 0.3, 1.0])
def test_relative_linear_quality_at_uniform_share_is_quality_at_uniform(n_types, q_u):
    params = _params(quality_model="relative-linear", n_types=n_types, quality_at_uniform=q_u,
                     types_per_composite=min(5, n_types))
    assert eq.atomic_quality(np.array([1.0 / n_types]), 0.7, params)[0] == pytest.approx(q_u, rel=1e-14)


def test_quality_hyperbolic_hand_computed():
    # h = 1/8, resource 0.5: x = w * 0.5; w = 0.05 -> x = 0.025 -> 0.025 / 0.15 = 1/6;
    # w = 0.25 -> x = h -> 1/2; w = 1 -> 0.5 / 0.625 = 0.8; w = 0 -> floor
    params = _params(quality_model="hyperbolic", half_saturation=0.125)
    out = eq.atomic_quality(np.array([0.05, 0.25, 1.0, 0.0]), 0.5, params)
    np.testing.assert_allclose(out, [1 / 6, 0.5, 0.8, 1e-6], rtol=1e-14)
    # the child's own resource counts: twice the resource, the quality of twice the weight
    np.testing.assert_allclose(eq.atomic_quality(np.array([0.05]), 1.0, params),
                               eq.atomic_quality(np.array([0.1]), 0.5, params), rtol=1e-15)


def test_quality_exponential_hand_computed():
    # h = 0.2, resource 0.4: w = 0.5 -> x = 0.2 = h -> 1 - 1/e; w = 1 -> 1 - e^-2
    params = _params(quality_model="exponential", half_saturation=0.2)
    out = eq.atomic_quality(np.array([0.5, 1.0]), 0.4, params)
    np.testing.assert_allclose(out, [1 - math.exp(-1), 1 - math.exp(-2)], rtol=1e-14)


def test_quality_with_load_sharing_divides_the_resource():
    # hyperbolic, h = 0.1, resource 0.8, w = 0.25: x = 0.2 alone -> 2/3; shared by 2 -> x = 0.1 -> 1/2;
    # by 4 -> x = 0.05 -> 1/3
    params = _params(quality_model="hyperbolic", half_saturation=0.1, load_sharing=True)
    out = eq.atomic_quality(np.array([0.25, 0.25, 0.25]), 0.8, params, np.array([1.0, 2.0, 4.0]))
    np.testing.assert_allclose(out, [2 / 3, 0.5, 1 / 3], rtol=1e-14)
    # relative-linear: the share is divided: 6 * 0.1 / 2 = 0.3
    linear = _params(quality_model="relative-linear", load_sharing=True)
    assert eq.atomic_quality(np.array([0.1]), 0.5, linear, 2.0)[0] == pytest.approx(0.3, rel=1e-14)


@pytest.mark.parametrize("model", ["hyperbolic", "exponential"])
def test_concave_qualities_rise_and_saturate_below_one(model):
    params = _params(quality_model=model, half_saturation=0.125)
    w = np.linspace(0.001, 1.0, 200)
    q = eq.atomic_quality(w, 1.0, params)
    assert (np.diff(q) > 0).all()
    assert (np.diff(q, 2) < 0).all()  # concave: each extra unit of resource is worth less
    assert (q < 1).all() and (q > 0).all()


def test_absent_quality_defaults_to_the_uniform_allocation_at_the_mean_resource():
    # hyperbolic h = 1/8: x = 0.5 / 20 = 0.025 -> 0.025 / 0.15 = 1/6
    assert _params(half_saturation=0.125).effective_absent_quality == pytest.approx(1 / 6, rel=1e-14)
    assert _params(quality_model="relative-linear").effective_absent_quality == pytest.approx(0.3, rel=1e-14)
    assert _params(absent_quality=0.4).effective_absent_quality == 0.4


def test_proportional_values_zero_noise_gives_profile():
    profile = np.array([0.2, 0.3, 0.5])
    out = eq.proportional_values(profile, np.array([1.0, -2.0, 0.5]), 0.0)
    np.testing.assert_allclose(out, profile, atol=1e-15)


def test_proportional_values_known_case():
    # value_noise = ln 2, noise [1, 0, 0]: [0.25 * 2, 0.25, 0.5] = [0.5, 0.25, 0.5] / 1.25 = [0.4, 0.2, 0.4]
    out = eq.proportional_values(np.array([0.25, 0.25, 0.5]), np.array([1.0, 0.0, 0.0]), math.log(2.0))
    np.testing.assert_allclose(out, [0.4, 0.2, 0.4], atol=1e-15)


def test_proportional_values_sum_to_one():
    rng = np.random.default_rng(0)
    for _ in range(20):
        profile = rng.dirichlet(np.ones(5))
        out = eq.proportional_values(profile, rng.standard_normal(5), 0.7)
        assert out.sum() == pytest.approx(1.0, abs=1e-14)
        assert (out > 0).all()


def test_composite_quality_and_absolute_values():
    ctv = np.array([0.4, 0.2, 0.4])
    quality = np.array([1.0, 0.5, 0.25])
    # taq = 0.4 + 0.1 + 0.1 = 0.6; atv = 0.6 * ctv = [0.24, 0.12, 0.24]
    taq = eq.composite_quality(ctv, quality)
    assert taq == pytest.approx(0.6, abs=1e-15)
    assert isinstance(taq, float)
    np.testing.assert_allclose(eq.absolute_values(ctv, taq), [0.24, 0.12, 0.24], atol=1e-15)
