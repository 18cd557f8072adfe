"""Bit-identical utilities whatever runs beside a seed, in whatever order and block size, and in
another process; common random numbers across algorithms."""

import subprocess
import sys

import numpy as np
import pytest

from mgrao_core import make_spec, run_experiment

SYSTEMS = ["single", "multi", "volatile", "large"]


def _by_run(result):
    return {(r.algorithm, r.seed): r.utilities for r in result.runs}


@pytest.mark.parametrize("system", SYSTEMS)
def test_same_spec_same_utilities(system):
    spec = make_spec(system, seeds=[0, 5], episodes=20)
    a, b = _by_run(run_experiment(spec)), _by_run(run_experiment(spec))
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key]), key


@pytest.mark.parametrize("system", SYSTEMS)
def test_seed_alone_or_with_others_in_any_order(system):
    together = _by_run(run_experiment(make_spec(system, seeds=[4, 1, 9], episodes=20)))
    reordered = _by_run(run_experiment(make_spec(system, seeds=[9, 4, 1], episodes=20)))
    alone = _by_run(run_experiment(make_spec(system, seeds=[1], episodes=20)))
    for key, utilities in alone.items():
        assert np.array_equal(together[key], utilities), key
        assert np.array_equal(reordered[key], utilities), key
    for key in together:
        assert np.array_equal(together[key], reordered[key]), key


@pytest.mark.parametrize("system", SYSTEMS)
def test_block_size_does_not_matter(system):
    spec = make_spec(system, seeds=[2, 3], episodes=21)
    whole = _by_run(run_experiment(spec, episodes_per_block=21))
    for block in (1, 7, 8):
        split = _by_run(run_experiment(spec, episodes_per_block=block))
        for key in whole:
            assert np.array_equal(whole[key], split[key]), (block, key)


def test_algorithm_lane_independent_of_other_algorithms():
    full = _by_run(run_experiment(make_spec("large", seeds=[3], episodes=15)))
    few = _by_run(run_experiment(make_spec("large", ["mgrao-25:1"], seeds=[3], episodes=15)))
    assert np.array_equal(full[("mgrao-25:1", 3)], few[("mgrao-25:1", 3)])


def test_different_seeds_differ():
    result = _by_run(run_experiment(make_spec("single", ["mgrao-max"], seeds=[0, 1], episodes=5)))
    assert not np.array_equal(result[("mgrao-max", 0)], result[("mgrao-max", 1)])


_SCRIPT = """
from mgrao_core import make_spec, run_experiment
result = run_experiment(make_spec("multi", ["uniform", "mgrao-max"], seeds=[6, 2], episodes=12))
for run in result.runs:
    print(run.algorithm, run.seed, run.utilities.tobytes().hex())
"""


def test_same_utilities_in_another_process():
    out = subprocess.run([sys.executable, "-c", _SCRIPT], capture_output=True, text=True, check=True,
                         timeout=300)
    lines = out.stdout.split()
    here = run_experiment(make_spec("multi", ["uniform", "mgrao-max"], seeds=[6, 2], episodes=12))
    expected = []
    for run in here.runs:
        expected += [run.algorithm, str(run.seed), run.utilities.tobytes().hex()]
    assert lines == expected
