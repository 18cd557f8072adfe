"""backend/execution/lifeline.py with real processes: a parent that starts a child, then dies by SIGKILL."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from backend_helpers import alive

from backend.execution.lifeline import SUPERVISOR_ENV
from tests.support.local_service import mgrao_command

pytestmark = pytest.mark.slow

PARENT = """
import os, subprocess, sys, time
child = subprocess.Popen(sys.argv[1:], env=dict(os.environ, **({%r: str(os.getpid())} if %r else {})))
print(child.pid, flush=True)
time.sleep(120)
"""

STUCK_CHILD = """
import signal, time
from backend.execution import lifeline
lifeline.GRACE_S = 1.0
signal.signal(signal.SIGTERM, signal.SIG_IGN)  # a worker that cannot stop (stuck in a long compile, say)
assert lifeline.bind_to_supervisor() is not None
print("bound", flush=True)
time.sleep(120)
"""


class Family:
    """A parent process and the child it started; everything left alive is killed by pid at the end."""

    def __init__(self, child_argv: list[str], *, supervised: bool, env: dict[str, str]) -> None:
        self.parent = subprocess.Popen([sys.executable, "-c", PARENT % (SUPERVISOR_ENV, supervised), *child_argv],
                                       env=env, stdout=subprocess.PIPE, text=True)
        self.child = int(self.read_line("the child's pid"))

    def read_line(self, what: str, timeout: float = 60) -> str:
        """The next line the parent (or the child, on the same pipe) prints, within ``timeout`` seconds."""
        assert self.parent.stdout is not None
        ready, _, _ = select.select([self.parent.stdout], [], [], timeout)
        assert ready, f"timed out after {timeout} s waiting for {what}"
        return self.parent.stdout.readline()

    def kill_parent(self) -> float:
        self.parent.send_signal(signal.SIGKILL)
        self.parent.wait()
        return time.monotonic()

    def close(self) -> None:
        if self.parent.poll() is None:
            self.parent.kill()
            self.parent.wait()
        if alive(self.child):
            os.kill(self.child, signal.SIGKILL)
        assert self.parent.stdout is not None
        self.parent.stdout.close()


@pytest.fixture
def families() -> Iterator[list[Family]]:
    started: list[Family] = []
    yield started
    for family in started:
        family.close()


def wait_gone(pid: int, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while alive(pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    return not alive(pid)


def test_a_supervised_process_that_ignores_sigterm_exits_hard_after_the_grace(families: list[Family]) -> None:
    family = Family([sys.executable, "-c", STUCK_CHILD], supervised=True, env=dict(os.environ))
    families.append(family)
    assert family.read_line("the child to bind to its supervisor").strip() == "bound"
    killed = family.kill_parent()
    assert wait_gone(family.child, timeout=30), "the child outlived its supervisor"
    assert time.monotonic() - killed >= 0.9  # not before the grace: SIGTERM alone did nothing


def test_a_worker_started_by_hand_outlives_the_shell_that_started_it(families: list[Family],
                                                                      tmp_path: Path) -> None:
    env = dict(os.environ, MGRAO_POLL_S="0.05")
    env.pop(SUPERVISOR_ENV, None)
    worker = mgrao_command("worker", "--database-url", f"sqlite:///{tmp_path / 'alone.db'}")
    family = Family(worker, supervised=False, env=env)
    families.append(family)
    family.kill_parent()
    time.sleep(2.0)  # four times the lifeline's poll interval
    assert alive(family.child), "a worker without a supervisor stopped when its parent died"
    os.kill(family.child, signal.SIGTERM)
    assert wait_gone(family.child, timeout=30), "the worker did not stop within 30 s of SIGTERM"


SIGNALLED = """
import os, signal, time
from backend.execution.lifeline import StopEvent, stop_on_signals
stop, calls = StopEvent(), []

def on_stop(*_):
    calls.append(1)
    os.kill(os.getpid(), signal.SIGTERM)  # a second SIGTERM while the first is handled
    time.sleep(0.01)  # (its handler would run here)
    stop.set()

stop_on_signals(on_stop)
with stop._cond:  # the main thread inside the flag's lock, as in a wait, when the signal lands
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(0.01)  # the handler runs here, in this thread, and takes the lock again
print(len(calls), stop.is_set(), stop.wait(0), flush=True)
"""


def test_a_stop_signal_that_lands_inside_the_stop_flags_lock_or_its_own_handler_does_not_hang(tmp_path: Path) -> None:
    # a worker started by serve's watcher thread got serve's SIGTERM and the parent-death SIGTERM at once: the
    # second handler ran inside the first one's threading.Event.set and waited for the lock that set held, and the
    # worker hung until it was killed 30 s later (seen in the suite's teardowns of test_supervisor.py)
    script = tmp_path / "signalled.py"
    script.write_text(SIGNALLED)
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    done = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split() == ["1", "True", "True"]  # one stop, the second signal dropped while it ran
