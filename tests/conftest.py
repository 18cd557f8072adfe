"""The whole suite's set-up: the project byte-compiled and its kernels compiled once, the slowest tests first, and the
census of kernels kept.

In a parallel run (the README's ``pytest -n auto --dist worksteal``, pytest-xdist) the controlling process compiles
the census of kernels (tests/support/kernels.py) before the workers start, as many at once as there are workers;
``--precompile yes`` does it in a run without workers too, ``--precompile no`` never. Tests then run slowest first
(tests/support/scheduling.py), so that the last minutes do not wait on one long test. Every test fails that runs
the kernel on a signature outside the census.
"""

from __future__ import annotations

import asyncio
from collections.abc import Iterator

import pytest

from tests.support import kernels, scheduling
from tests.support.project import ROOT, packages


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


def byte_compile_the_project() -> None:
    """Byte-compile the project's packages (pyproject.toml's) and the tests' helpers, once, before the tests.

    An editable install leaves the project's own sources uncompiled, and the tests start hundreds of Python processes
    that import them (servers, workers, command lines): where ``PYTHONDONTWRITEBYTECODE`` is set, each compiled them
    from source again (importing the API and the worker: 1.0 CPU-s, against 0.83 with them compiled). ``compileall``
    writes the files whatever that variable says, and every process reads them.
    """
    import compileall

    for name in [*packages(), "tests/support"]:
        if (ROOT / name).is_dir():
            compileall.compile_dir(ROOT / name, quiet=1)


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    """Byte-compile the project, then compile the census before xdist starts its workers (its own sessionstart comes
    after this one)."""
    config = session.config
    if hasattr(config, "workerinput"):
        return
    byte_compile_the_project()
    mode = config.getoption("precompile")
    if mode == "no" or (mode == "auto" and not _workers(config)):
        return
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    write = reporter.write_line if reporter is not None else lambda line, **_: print(line)
    try:
        done = kernels.precompile(processes=max(1, _workers(config)))
    except RuntimeError as error:  # the tests that need a kernel compile it, and fail, each with its own traceback
        write(f"kernels: compiling the census failed, the tests compile what they need: {error}", red=True)
        return
    slowest = sorted(done.seconds.items(), key=lambda item: -item[1])[:3]
    write(f"kernels: {len(done.seconds)} signatures compiled or loaded in {done.wall:.1f} s by {done.processes} "
          "processes (slowest: " + ", ".join(f"{name} {s:.0f} s" for name, s in slowest) + ")")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    scheduling.slowest_first(config, items)


@pytest.fixture(autouse=True)
def _kernels_of_the_census() -> Iterator[None]:
    """Fail a test that ran the kernel on a signature outside the census (see tests/support/kernels.py)."""
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
