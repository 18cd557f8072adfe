"""The per-test deadline of pyproject.toml: a test that hangs fails alone, and its fixtures still clean up."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

HANGING = """
import time

import pytest


@pytest.fixture
def server():
    yield
    open({stopped!r}, "w").write("stopped")  # where a real fixture stops the processes it started


def test_hangs(server):
    time.sleep(3600)


def test_after_it():
    pass
"""


def test_the_suite_has_a_per_test_deadline_far_above_its_slowest_test(pytestconfig: pytest.Config) -> None:
    assert float(pytestconfig.getini("timeout")) >= 600
    assert pytestconfig.getini("timeout_method") == "signal"  # the thread method would end the whole run at once


@pytest.mark.parametrize("workers", [[], ["-n", "2", "--dist", "worksteal"]], ids=["one-process", "xdist"])
def test_a_hanging_test_fails_alone_and_its_fixtures_teardown_runs(tmp_path: Path, workers: list[str]) -> None:
    # also on pytest-xdist's workers, as the README's command runs the suite: SIGALRM needs the test in the main thread
    stopped = tmp_path / "stopped"
    (tmp_path / "test_hang.py").write_text(HANGING.format(stopped=str(stopped)))
    # the project's own settings, with a deadline of 2 s instead of the suite's
    done = subprocess.run([sys.executable, "-m", "pytest", "-c", str(ROOT / "pyproject.toml"), "-o", "timeout=2",
                           "-p", "no:cacheprovider", "-q", *workers, str(tmp_path / "test_hang.py")],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "1 failed, 1 passed" in done.stdout and "Timeout (>2.0s)" in done.stdout, done.stdout
    assert stopped.read_text() == "stopped"
