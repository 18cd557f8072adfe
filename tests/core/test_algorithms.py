"""Algorithm labels and the parent groups they imply."""

import numpy as np
import pytest

from mgrao_core import ConfigError, divisors, parent_groups, parse_algorithm
from mgrao_core.algorithms import parse_algorithms


@pytest.mark.parametrize("n", [1, 7, 10, 12, 50, 60])
def test_parent_groups_for_every_divisor(n):
    for x in divisors(n):
        groups = parent_groups(n, x)
        assert groups.shape == (n,)
        size = n // x
        np.testing.assert_array_equal(np.bincount(groups, minlength=x), np.full(x, size))
        assert (np.diff(groups) >= 0).all()  # contiguous blocks in parent order
        np.testing.assert_array_equal(groups, np.arange(n) // size)


def test_parent_groups_examples():
    np.testing.assert_array_equal(parent_groups(10, 2), [0, 0, 0, 0, 0, 1, 1, 1, 1, 1])
    np.testing.assert_array_equal(parent_groups(10, 1), np.zeros(10))
    np.testing.assert_array_equal(parent_groups(10, 10), np.arange(10))


def test_divisors():
    assert divisors(10) == [1, 2, 5, 10]
    assert divisors(50) == [1, 2, 5, 10, 25, 50]
    assert divisors(1) == [1]
    assert divisors(7) == [1, 7]


def test_parse_labels():
    assert parse_algorithm("uniform", 10).kind == "uniform"
    assert parse_algorithm("oracle", 10).kind == "oracle"
    assert parse_algorithm("mgrao-max", 50).n_groups == 50
    alg = parse_algorithm("mgrao-5:1", 50)
    assert (alg.label, alg.kind, alg.n_groups) == ("mgrao-5:1", "mgrao", 5)
    assert parse_algorithm("mgrao-1:1", 10).n_groups == 1


@pytest.mark.parametrize(("label", "n", "valid"), [
    ("mgrao-3:1", 10, "1, 2, 5, 10"),
    ("mgrao-4:1", 50, "1, 2, 5, 10, 25, 50"),
    ("mgrao-11:1", 10, "1, 2, 5, 10"),
    ("mgrao-0:1", 10, "1, 2, 5, 10"),
])
def test_non_divisor_is_rejected_with_the_valid_divisors(label, n, valid):
    with pytest.raises(ConfigError) as info:
        parse_algorithm(label, n, "algorithms[1]")
    assert info.value.field == "algorithms[1]"
    assert f"valid: {valid}" in info.value.message
    assert f"n_parents = {n}" in info.value.message


def test_a_ratio_whose_y_does_not_divide_the_children_is_rejected_naming_the_valid_values():
    with pytest.raises(ConfigError) as info:
        parse_algorithm("mgrao-2:3", 10, n_children=4)
    assert info.value.field == "algorithm"
    assert "y must be a divisor of n_children = 4" in info.value.message and "1, 2, 4" in info.value.message


@pytest.mark.parametrize("label", ["greedy", "mgrao", "mgrao-x:1", "mgrao-1:1:1", "mgrao-1234567890:1", "", None, 3])
def test_unknown_labels(label):
    with pytest.raises(ConfigError) as info:
        parse_algorithm(label, 10)
    assert "unknown algorithm" in info.value.message
    assert "a whole number dividing n_parents = 10 (1, 2, 5, 10)" in info.value.message  # what x may be


def test_parse_algorithms_list_errors():
    with pytest.raises(ConfigError) as info:
        parse_algorithms([], 10)
    assert info.value.field == "algorithms"
    with pytest.raises(ConfigError) as info:
        parse_algorithms(["uniform", "mgrao-1:1", "uniform"], 10)
    assert info.value.field == "algorithms[2]"
    assert "repeat" in info.value.message
    with pytest.raises(ConfigError) as info:
        parse_algorithms(["uniform", "mgrao-1:1", "mgrao-7:1"], 10)
    assert info.value.field == "algorithms[2]"
