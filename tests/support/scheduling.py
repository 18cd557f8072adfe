"""The order of a parallel run: the slowest tests first, dealt so that every worker starts on some of them.

pytest-xdist's work stealing (``--dist worksteal``) first gives each of its N workers a contiguous 1/N of the
collected tests, then lets an idle worker take half of the rest of another's. A run ends when its last test does:
a long test that comes late leaves the other workers idle meanwhile. :func:`slowest_first` orders units of tests
by their time (tests/support/durations.json: a long test is a unit of its own, and the other tests of a file are
one; a unit it does not list counts as quick), deals them, slowest first, to N shares of equal counts (each unit
to the share with the least time), and puts the shares one after the other, so that each worker's own part
begins with its slow units. A file's other tests stay together and in their order (its module fixtures are set
up once per worker), and units of equal time keep the order they came in (a random one under ``-p randomly``).
A module marked ``same_worker`` is one unit whatever the file lists, its time the sum of its tests': its tests share
a module fixture whose work the later ones reuse (the quick start's clone and home, where the second order loads
the engine the first compiled), which tests dealt to two workers would each do again.
``python benchmarks/bench_suite.py --durations JUNIT.xml`` rewrites the file from a run's JUnit report.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

DURATIONS = Path(__file__).with_name("durations.json")


def durations() -> dict[str, float]:
    """Seconds by node id (a long test) or by file (its other tests), as tests/support/durations.json has them."""
    try:
        return json.loads(DURATIONS.read_text())
    except FileNotFoundError:
        return {}


def _workers(config: pytest.Config) -> int:
    """The number of xdist workers when this process is one of them, else 0."""
    workerinput = getattr(config, "workerinput", None)
    if workerinput is None:
        return 0
    return int(workerinput.get("workercount", os.environ.get("PYTEST_XDIST_WORKER_COUNT", 1)))


def slowest_first(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Reorder ``items`` in place for a run on xdist's workers (see the module); one process keeps their order."""
    workers = _workers(config)
    if workers >= 2:
        items[:] = deal(items, durations(), workers)


def deal(items: list[pytest.Item], listed: dict[str, float], workers: int) -> list[pytest.Item]:
    """``items`` in the order :func:`slowest_first` gives them, with the seconds ``listed`` by node id or file."""
    files: dict[str, list[pytest.Item]] = {}
    seconds: dict[str, float] = {}  # each unit's
    for item in items:  # a unit: a test listed on its own, or the other tests of a file, or a same_worker module
        alone = item.nodeid in listed and item.get_closest_marker("same_worker") is None
        name = item.nodeid if alone else item.nodeid.split("::", 1)[0]
        files.setdefault(name, []).append(item)
        if name not in seconds:
            seconds[name] = listed.get(name, 0.0)  # a long test's own time, or a file's other tests'
        if not alone:
            seconds[name] += listed.get(item.nodeid, 0.0)  # a long test of a same_worker module, in its module's unit
    by_time = sorted(files, key=lambda name: -seconds[name])  # stable: equal times keep their order
    sizes = []
    left = len(items)
    for i in range(workers):  # the counts xdist gives: len(pending) // workers_remaining, in turn
        sizes.append(left // (workers - i))
        left -= sizes[-1]
    shares: list[list[pytest.Item]] = [[] for _ in range(workers)]
    times = [0.0] * workers
    for name in by_time:
        tests = files[name]
        while tests:
            open_ = [i for i in range(workers) if len(shares[i]) < sizes[i]]
            i = min(open_, key=lambda k: times[k])
            taken, tests = tests[: sizes[i] - len(shares[i])], tests[sizes[i] - len(shares[i]):]
            shares[i].extend(taken)
            times[i] += seconds[name] * len(taken) / len(files[name])
    return [item for share in shares for item in share]
