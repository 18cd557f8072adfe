"""Sparse worlds (issue 42): each parent offers its tasks to some children (docs/model.md, "Sparse worlds").

The engine equals the dense per-agent reference under every topology on small worlds; the complete topology is
today's world, bit for bit; a world's links are the ring's nearest children or a seed's random draw; the memory a
job needs follows its links, and what would not fit is refused naming the bytes.
"""

from __future__ import annotations

import numpy as np
import pytest

from mgrao_core import ConfigError, make_params, make_spec, run_experiment
from mgrao_core.world import draw_links

from ._helpers import assert_matches_reference


def test_a_ring_links_each_parent_to_its_nearest_children():
    ring = draw_links(make_params({"n_children": 10, "n_parents": 5, "topology": "ring", "children_per_parent": 3}),
                      0)
    # parent p sits at (p + 1/2) / 5 of the ring, child c at (c + 1/2) / 10: parent 1 (0.3) is nearest 2, 3, then 1
    assert ring.tolist() == [[0, 1, 9], [1, 2, 3], [3, 4, 5], [5, 6, 7], [7, 8, 9]]
    few_children = draw_links(make_params({"n_children": 4, "n_parents": 8, "topology": "ring",
                                           "children_per_parent": 2}), 0)
    assert few_children.tolist() == [[0, 3], [0, 1], [0, 1], [1, 2], [1, 2], [2, 3], [2, 3], [0, 3]]
    assert draw_links(make_params({"n_children": 4, "n_parents": 8}), 0) is None  # complete: nothing drawn


@pytest.mark.parametrize("children, k", [(10, 3), (10_000, 8), (20, 20)])
def test_random_links_are_distinct_children_drawn_with_the_seed(children, k):
    params = make_params({"n_children": children, "n_parents": 2000, "topology": "random", "children_per_parent": k})
    links = draw_links(params, 7)
    assert links.shape == (2000, k) and links.min() >= 0 and links.max() < children
    assert (np.diff(links, axis=1) > 0).all()  # distinct, in increasing order
    np.testing.assert_array_equal(links, draw_links(params, 7))
    assert not np.array_equal(links, draw_links(params, 8)) or k == children
    if k < children:  # every child is as likely to be drawn
        counts = np.bincount(links.ravel(), minlength=children)
        expected = 2000 * k / children
        assert abs(counts.mean() - expected) < 1e-9 and counts.std() < 4 * np.sqrt(expected)


def test_a_neighbourhood_larger_than_the_children_is_refused_naming_the_field():
    with pytest.raises(ConfigError) as error:
        make_params({"n_children": 4, "topology": "ring", "children_per_parent": 5})
    assert error.value.field == "children_per_parent" and "at most n_children = 4" in error.value.message
    assert make_params({"n_children": 4, "children_per_parent": 5}).children_offered == 4  # complete: unused


SPARSE = [
    {"n_children": 6, "n_parents": 12, "topology": "ring", "children_per_parent": 3},
    {"n_children": 6, "n_parents": 12, "topology": "random", "children_per_parent": 2, "routing": "per-task"},
    {"n_children": 5, "n_parents": 9, "topology": "random", "children_per_parent": 1},
    {"n_children": 4, "n_parents": 12, "topology": "ring", "children_per_parent": 2, "load_sharing": True,
     "leave_probability": 0.2, "join_probability": 0.3},
]


@pytest.mark.parametrize("overrides", SPARSE)
def test_the_engine_equals_the_reference_in_sparse_worlds(overrides):
    algorithms = ["uniform", "mgrao-1:1", "mgrao-3:1", "mgrao-max", "oracle"]
    result = run_experiment(make_spec("multi", algorithms, [3, 11], 25, overrides))
    assert_matches_reference(result)


def test_ring_links_to_every_child_are_the_complete_world():
    # k = n_children on a ring: every parent offers its tasks to every child, in the order of their index
    complete = run_experiment(make_spec("multi", ["uniform", "mgrao-1:1"], [5], 30))
    ring = run_experiment(make_spec("multi", ["uniform", "mgrao-1:1"], [5], 30,
                                    {"topology": "ring", "children_per_parent": 3}))
    for a, b in zip(complete.runs, ring.runs, strict=True):
        np.testing.assert_array_equal(a.utilities, b.utilities)


BIG = {"n_children": 10_000, "n_parents": 100_000, "topology": "ring", "children_per_parent": 8}


def test_what_would_not_fit_is_refused_naming_the_bytes_and_what_fits_is_not():
    # the paper's point measured: groups fit where a row per parent does not
    from mgrao_core.budget import chunk_cost
    from mgrao_core.errors import WorkLimitError

    fits = make_spec("multi", ["uniform", "mgrao-100:1"], [0], 100, BIG)
    assert chunk_cost(fits, 1).total < 2 * 1024**3
    with pytest.raises(WorkLimitError) as error:
        make_spec("multi", ["uniform", "mgrao-max"], [0], 100, BIG)
    assert error.value.field == "memory"
    assert "MiB, over the memory budget of 2,048 MiB per chunk" in error.value.message
    needed = float(error.value.message.split("would need ")[1].split(" MiB")[0].replace(",", ""))
    assert needed > 300 * 1024  # more than 300 GiB: a row of PW and trace for each of 100,000 parents, per child
    with pytest.raises(WorkLimitError) as error:  # a complete world of that size: its estimates alone
        make_spec("multi", ["uniform"], [0], 100, {"n_children": 10_000, "n_parents": 100_000})
    assert error.value.field == "memory"
    with pytest.raises(WorkLimitError):  # adaptive keeps statistics of every parent for every child, and visits them
        make_spec("multi", ["mgrao-adaptive:100"], [0], 100, BIG)
    # what grows with the children rather than the tasks counts towards the work limit
    small = make_spec("multi", ["mgrao-adaptive:2"], [0, 1], 10, {"n_children": 50, "n_parents": 40})
    assert small.group_updates == 2 * (10 * 40 * 5 * 2 + 10 * 40 * 50)
