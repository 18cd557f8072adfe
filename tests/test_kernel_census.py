"""The census of the suite's kernels (tests/support/kernels.py): what the tests may compile, each with its cost.

Every signature of the kernel is one more compile of a quarter of a minute to a few minutes on a new install, in
CI and for whoever runs the suite; tests/conftest.py fails a test that runs the kernel outside the census, and a
parallel run compiles the census beside its first tests, those that compile in caches of their own, while the
others wait for it. These tests keep the census, that wait and that order true.
"""

from __future__ import annotations

import inspect
import json
import os
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

from mgrao_core.algorithms import LEARNERS
from mgrao_core.engine.kernel import run_block
from tests.support import scheduling
from tests.support.kernels import CENSUS, CENSUS_ENV, OPTIONAL, PARTS, Beside, in_census, signature_of, wait_for_census
from tests.support.waiting import wait_until

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


def _compilers() -> list[int]:
    """This process's children that compile the census (``python -m tests.support.kernels serve``)."""
    children = Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children").read_text().split()
    found = []
    for pid in children:
        try:
            if b"tests.support.kernels" in Path(f"/proc/{pid}/cmdline").read_bytes():
                found.append(int(pid))
        except FileNotFoundError:  # ended meanwhile
            pass
    return found


def test_the_census_compiled_beside_the_tests_says_when_it_is_done(tmp_path: Path) -> None:
    # this suite's census is compiled (the test waited for it): loading it again in two processes takes seconds
    outcome = tmp_path / "census.json"
    beside = Beside(outcome, processes=2)
    wait_until(outcome.exists, 600, "the census loaded again")
    beside.close()
    assert json.loads(outcome.read_text()) == {"ok": True, "error": None}
    assert beside.done is not None and sorted(beside.done.seconds) == ALLOWED and not beside.stopped
    assert _compilers() == []


def test_a_census_stopped_before_it_is_done_kills_its_processes_and_says_so(tmp_path: Path) -> None:
    beside = Beside(tmp_path / "census.json", processes=2)  # a run whose tests all ended first
    beside.close()
    assert beside.stopped and beside.done is None and beside.error.startswith("stopped: the tests ended first")
    assert json.loads((tmp_path / "census.json").read_text())["ok"] is False  # a test still waiting goes on
    assert _compilers() == []


def test_a_test_waits_for_the_census_only_while_one_is_compiled_beside_it(tmp_path: Path,
                                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(CENSUS_ENV, raising=False)
    assert wait_for_census() == 0.0  # a run without a census beside it (one process, --precompile no)
    outcome = tmp_path / "census.json"
    monkeypatch.setenv(CENSUS_ENV, str(outcome))
    writer = threading.Timer(0.5, lambda: outcome.write_text('{"ok": true, "error": null}'))
    writer.start()
    try:
        assert 0.4 <= wait_for_census(timeout=30) < 30
    finally:
        writer.cancel()
    assert wait_for_census() == 0.0  # once done, at once
    monkeypatch.setenv(CENSUS_ENV, str(tmp_path / "never.json"))
    with pytest.raises(AssertionError, match="timed out after 0.3 s waiting for the census of kernels"):
        wait_for_census(timeout=0.3)


def test_the_tests_that_compile_in_caches_of_their_own_are_dealt_first(monkeypatch: pytest.MonkeyPatch) -> None:
    # they run while the census is compiled; the others wait for it (tests/support/scheduling.py)
    def item(nodeid: str, own: bool = False) -> SimpleNamespace:
        marker = pytest.mark.own_kernels.mark if own else None
        return SimpleNamespace(nodeid=nodeid, get_closest_marker=lambda name: marker if name == "own_kernels" else None)

    seconds = {"a.py::slow": 100.0, "b.py": 50.0, "c.py::own": 30.0, "d.py": 20.0, "e.py": 10.0}
    monkeypatch.setattr(scheduling, "durations", lambda: seconds)
    items = [item("a.py::slow"), item("b.py::x"), item("b.py::y"), item("c.py::own", own=True), item("d.py::z", True),
             item("e.py::w")]
    config = SimpleNamespace(workerinput={"workercount": 2})
    scheduling.slowest_first(config, items)  # two shares of three, one after the other
    # c and d (own) go to the two shares first, then the rest slowest first, each to the share with the least time
    assert [i.nodeid for i in items] == ["c.py::own", "b.py::x", "b.py::y", "d.py::z", "a.py::slow", "e.py::w"]
