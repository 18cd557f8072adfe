"""The census of the suite's kernels (tests/support/kernels.py): what the tests may compile, each with its cost.

Every signature of the kernel is one more compile of a quarter of a minute to a few minutes on a new install, in
CI and for whoever runs the suite; tests/conftest.py fails a test that runs the kernel outside the census, and a
parallel run compiles the census before its first test. These tests keep the census itself true.
"""

from __future__ import annotations

import inspect

import pytest

from mgrao_core.algorithms import LEARNERS
from mgrao_core.engine.kernel import run_block
from tests.support.kernels import CENSUS, OPTIONAL, PARTS, _steps, in_census, next_to_compile, signature_of

ALLOWED = sorted(CENSUS)


def test_the_census_names_every_optional_argument_of_the_kernel() -> None:
    # a new argument that may be None doubles what can be compiled: each signature the tests give it is another
    # compile (tests/support/kernels.py says how to weigh one), so a new one must come here, and into the census
    parameters = list(inspect.signature(run_block.py_func).parameters)
    assert parameters == ["lanes", "worlds", "several", "links", "draws", "env", "utilities", "outside", "failing",
                          *OPTIONAL[4:]], "run_block's arguments changed: update OPTIONAL and the census"
    assert len(OPTIONAL[4:]) == len(LEARNERS) and PARTS[4:] == tuple(family.name for family in LEARNERS)


@pytest.mark.parametrize("name", ALLOWED)
def test_each_recipe_calls_the_kernel_with_the_signature_it_is_listed_under(name: str) -> None:
    assert signature_of(CENSUS[name]) == name


def test_the_census_is_small_and_says_what_each_signature_costs() -> None:
    # the allowed signatures, with their compile times alone (python -m tests.support.kernels measure)
    assert len(ALLOWED) <= 9, f"{len(ALLOWED)} kernels to compile for the tests: {ALLOWED}"
    assert all(recipe.seconds > 0 for recipe in CENSUS.values())


def test_a_chunk_of_fewer_families_runs_on_the_census_kernel_of_every_family_of_its_world() -> None:
    # the runner runs it there, unless numba's cache holds its own kernel (a user's may): neither compiles
    every = "+".join(PARTS[4:])
    assert in_census("fixed") and in_census("mgrao") and in_census("independent-q+bandit")
    assert in_census(f"several+failing+{every}") and in_census("several+failing+mgrao-balance")
    assert not in_census("failing") and not in_census("links+mgrao-balance")  # no kernel of every family there
    assert in_census("links+mgrao") and in_census("several+outside")  # the census's own


def test_an_idle_compiler_waits_for_steps_another_is_compiling_unless_one_signature_is_left() -> None:
    every = "+".join(PARTS[4:])
    one, several, failing = every, f"several+{every}", f"several+failing+{every}"
    longest_first = sorted(CENSUS, key=lambda name: -CENSUS[name].seconds)
    assert longest_first[0] == one and next_to_compile(longest_first, set(), set()) == one
    # while the first kernel of every family compiles its families' steps, the other process takes what needs none
    compiling = _steps(one)
    free = next_to_compile(longest_first[1:], set(), compiling)
    assert free is not None and not _steps(free) & compiling and free not in (several, failing)
    assert next_to_compile([several, failing], set(), compiling) is None  # two left that need them: it waits
    # at the end: the other compiles several resources' balance steps for `several`, and `failing` is left alone
    cached = compiling | {"failing"}
    assert next_to_compile([failing], cached, _steps(several) - cached) == failing
    assert next_to_compile([], cached, set()) is None
