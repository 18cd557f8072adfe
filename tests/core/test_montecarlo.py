"""The oracle's compiled Monte-Carlo steps draw and add exactly as numpy does."""

import numpy as np
import pytest

from mgrao_core.engine.montecarlo import add_proportional_values, draw_scaled_normals, pairwise_sum
from mgrao_core.world import stream


def test_pairwise_sum_is_numpys_sum_to_the_bit():
    rng = np.random.default_rng(0)
    values = rng.lognormal(0.0, 3.0, size=1200) * rng.choice([1.0, 1e-9, 1e9], size=1200)
    for n in list(range(0, 300)) + [383, 384, 385, 511, 512, 513, 1000, 1100]:
        for start in (0, 3, 100):
            assert pairwise_sum(values, start, n) == values[start : start + n].sum(), (n, start)


@pytest.mark.parametrize("shape", [(1, 1, 1), (3, 10, 5), (2, 7, 200)])
def test_scaled_normals_are_the_generators_own_draws(shape):
    compiled, plain = stream(11, "oracle"), stream(11, "oracle")
    out = np.empty(shape)
    for _ in range(3):
        draw_scaled_normals(compiled, 0.25, out)
        np.testing.assert_array_equal(out, 0.25 * plain.standard_normal(shape))
    # the stream moved on exactly as numpy's draw moves it
    np.testing.assert_array_equal(compiled.standard_normal(100), plain.standard_normal(100))


def test_proportional_values_add_up_as_numpys_reductions():
    rng = np.random.default_rng(2)
    profiles = rng.dirichlet(np.full(150, 0.05), size=9)
    factors = np.exp(2.0 * rng.standard_normal((6, 9, 150)))
    noisy = profiles * factors
    expected = (noisy / noisy.sum(axis=2, keepdims=True)).sum(axis=0)
    sums = np.full((9, 150), np.nan)  # ignored: the first sample starts the sums
    scratch = np.empty(150)
    add_proportional_values(profiles, factors, True, sums, scratch)
    np.testing.assert_array_equal(sums, expected)
    # in two parts: the second adds its samples to the sums, one after the other
    add_proportional_values(profiles, factors[:4], True, sums, scratch)
    add_proportional_values(profiles, factors[4:], False, sums, scratch)
    np.testing.assert_array_equal(sums, expected)
