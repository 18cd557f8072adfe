"""The parallel run's order (tests/support/scheduling.py): slowest units first, dealt to every worker, and a
``same_worker`` module one unit, so that its tests reuse their module fixture's work on one worker."""

from __future__ import annotations

import pytest

from tests.support.scheduling import deal, slowest_first

pytest_plugins = ["pytester"]

MODULE = """
import pytest
{mark}
def test_first(): pass
def test_second(): pass
def test_third(): pass
"""
QUICK = "import pytest\n" + "".join(f"def test_quick_{n}(): pass\n" for n in range(6))


def _items(pytester: pytest.Pytester, mark: str) -> list[pytest.Item]:
    pytester.makeini("[pytest]\nmarkers =\n    same_worker: one unit\n")
    pytester.makepyfile(test_long=MODULE.format(mark=mark), test_quick=QUICK)
    items, _ = pytester.inline_genitems("-p", "no:randomly")  # in the files' order
    assert [item.name for item in items][:3] == ["test_first", "test_second", "test_third"] and len(items) == 9
    return items


def _worker_of(order: list[pytest.Item], workers: int = 2) -> dict[str, int]:
    """Which worker's first share each test is in (xdist deals the shares in equal counts, in turn)."""
    size = len(order) // workers
    return {item.name: min(i // size, workers - 1) for i, item in enumerate(order)}


def test_long_tests_are_units_of_their_own_and_start_every_workers_share(pytester: pytest.Pytester) -> None:
    items = _items(pytester, "")
    listed = {"test_long.py::test_first": 50.0, "test_long.py::test_second": 40.0, "test_long.py": 1.0,
              "test_quick.py": 3.0}
    order = deal(items, listed, 2)
    worker = _worker_of(order)
    assert worker["test_first"] != worker["test_second"]  # the two long ones apart, each first in its share
    assert {order[0].name, order[len(order) // 2].name} == {"test_first", "test_second"}
    assert sorted(i.nodeid for i in order) == sorted(i.nodeid for i in items)


def test_a_same_worker_module_is_one_unit_timed_as_the_sum_of_its_tests(pytester: pytest.Pytester) -> None:
    items = _items(pytester, "pytestmark = pytest.mark.same_worker")
    listed = {"test_long.py::test_first": 50.0, "test_long.py::test_second": 40.0, "test_long.py": 1.0,
              "test_quick.py": 3.0}  # the same times as above: there the two long tests go to two workers
    order = deal(items, listed, 2)
    worker = _worker_of(order)
    assert len({worker["test_first"], worker["test_second"], worker["test_third"]}) == 1  # together, on one worker
    names = [item.name for item in order]
    assert names.index("test_first") < names.index("test_second") < names.index("test_third")  # in their order
    assert names[0] == "test_first" and worker["test_quick_0"] != worker["test_first"]  # 91 s, first; the rest apart


def test_one_process_keeps_the_collected_order(pytester: pytest.Pytester) -> None:
    items = _items(pytester, "")
    collected = list(items)
    slowest_first(pytester.parseconfig(), items)  # not an xdist worker
    assert items == collected
