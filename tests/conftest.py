"""The whole suite's set-up: its kernels compiled once, the slowest tests first, and the census of kernels kept.

In a parallel run (the README's ``pytest -n auto --dist worksteal``, pytest-xdist) the controlling process compiles
the census of kernels (tests/support/kernels.py) while the first tests run, as many at once as there are workers;
``--precompile yes`` does it in a run without workers too, ``--precompile no`` never. The tests that compile from
scratch in caches of their own (marked ``own_kernels``) run first, the others wait for the census, and each part
runs slowest first (tests/support/scheduling.py), so that the last minutes do not wait on one long test. Every
test fails that runs the kernel on a signature outside the census.
"""

from __future__ import annotations

import asyncio
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support import kernels, scheduling


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--precompile", choices=("auto", "yes", "no"), default="auto",
                     help="compile the census of kernels (tests/support/kernels.py) before the tests: auto (default) "
                          "in a parallel run (pytest -n), yes, or no")


def pytest_configure(config: pytest.Config) -> None:
    kernels.serialise_cache_writes()  # this run's processes may compile signatures of one kernel at once


def _workers(config: pytest.Config) -> int:
    """How many xdist workers this run has (0 without xdist, or in a worker)."""
    if hasattr(config, "workerinput"):
        return 0
    numprocesses = getattr(config.option, "numprocesses", None) or 0
    return int(numprocesses) if getattr(config.option, "dist", "no") != "no" else 0


_census: kernels.Beside | None = None


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    """Start compiling the census before xdist starts its workers (its own sessionstart comes after this one): they
    inherit where it says it is done (:data:`kernels.CENSUS_ENV`)."""
    global _census
    config = session.config
    mode = config.getoption("precompile")
    if hasattr(config, "workerinput") or mode == "no" or (mode == "auto" and not _workers(config)):
        return
    outcome = Path(tempfile.mkdtemp(prefix="mgrao-census-")) / "census.json"
    os.environ[kernels.CENSUS_ENV] = str(outcome)
    _census = kernels.Beside(outcome, processes=max(1, _workers(config)))


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Stop the census's compile if the tests ended first (a run of a few tests)."""
    if _census is not None:
        _census.close()
        os.environ.pop(kernels.CENSUS_ENV, None)
        shutil.rmtree(_census.outcome.parent, ignore_errors=True)


def pytest_terminal_summary(terminalreporter: pytest.TerminalReporter) -> None:
    """Say what the census's compile did."""
    global _census
    census, _census = _census, None
    if census is None:
        return
    if census.stopped:  # a run of a few tests, which needed none of what was left
        terminalreporter.write_line(f"kernels: the census's compile was {census.error}")
    elif census.done is None:  # the tests that needed a kernel compiled it, and failed, each with its own traceback
        terminalreporter.write_line(f"kernels: compiling the census failed, the tests compiled what they needed: "
                                    f"{census.error}", red=True)
    else:
        done = census.done
        slowest = ", ".join(f"{name} {s:.0f} s" for name, s in sorted(done.seconds.items(), key=lambda i: -i[1])[:3])
        terminalreporter.write_line(f"kernels: {len(done.seconds)} signatures compiled or loaded in {done.wall:.1f} s "
                                    f"by {done.processes} processes beside the first tests (slowest: {slowest})")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    scheduling.slowest_first(config, items)


@pytest.fixture(scope="session")
def census() -> None:
    """The census of kernels compiled, when this run compiles it beside its first tests: for a fixture wider than a
    test that runs the kernel, or starts processes that do (a test's own wait comes after such fixtures)."""
    kernels.wait_for_census()


@pytest.fixture(autouse=True)
def _kernels_of_the_census(request: pytest.FixtureRequest) -> Iterator[None]:
    """Wait for the census unless the test compiles in a cache of its own (``own_kernels``), then fail the test if it
    ran the kernel on a signature outside the census (see tests/support/kernels.py)."""
    if request.node.get_closest_marker("own_kernels") is None:
        waited = kernels.wait_for_census()
        if waited >= 0.1:  # not the test's own time: tests/support/durations.json leaves it out
            request.node.user_properties.append(("census_wait_s", round(waited, 1)))
    before = len(kernels.loaded_signatures())
    yield
    signatures = kernels.loaded_signatures()
    names = [kernels.kernel_name(signature) for signature in signatures]
    outside = sorted({name for name in names[before:] if not kernels.in_census(name)})
    if outside:
        pytest.fail(f"this test ran the kernel on {', '.join(outside)}, a signature outside the census of "
                    "tests/support/kernels.py (each is one more compile): run one of the census instead (the families "
                    "of another test beside yours), or add it there with its compile time (python -m "
                    "tests.support.kernels measure NAME)", pytrace=False)
    twice = sorted({name for name in names[before:] if names.count(name) > 1})
    if twice:
        pytest.fail(f"the kernel was compiled twice for {', '.join(twice)}: an argument's type differs between two "
                    "calls with the same families (one more compile each time)", pytrace=False)


@pytest.fixture(autouse=True)
def _without_the_browsers_event_loop(request: pytest.FixtureRequest) -> Iterator[None]:
    """Run a test that does not drive the browser outside Playwright's event loop.

    Playwright's sync API keeps its event loop marked as running in the main thread for as long as the session's
    ``browser`` (tests/frontend/conftest.py) lives, and ``asyncio.run()`` refuses to start under a running loop. On
    one process the browser tests came last; on xdist's workers other tests follow them, and run without it.
    """
    loop = asyncio._get_running_loop()
    if loop is None or "browser" in request.fixturenames:
        yield
        return
    asyncio._set_running_loop(None)
    try:
        yield
    finally:
        asyncio._set_running_loop(loop)
