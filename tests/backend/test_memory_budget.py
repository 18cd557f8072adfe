"""The job memory budget is an honest bound: a real worker running the largest accepted job of each
shape stays within 1.25 times the budget above its own baseline.

Each shape stresses one kind of array :mod:`mgrao_core.budget` counts (learner state, the oracle's
Monte-Carlo temporaries, a block's random draws, the utilities of a chunk of seeds and their stored
copies). For each, the test finds the largest configuration ``make_spec`` accepts under the budget
(one step more is refused, naming the budget), runs it in a real ``mgrao worker`` process on a real
SQLite file, and reads the worker's peak resident memory (``VmHWM``) from ``/proc``. A budget of
256 MiB keeps the test short; the estimate scales with the sizes, not with the budget.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from backend.store import crud
from backend.store.db import Database
from backend.store.models import Job
from mgrao_core import ConfigError, ExperimentSpec, WorkLimitError, make_spec
from mgrao_core.budget import chunk_cost, plan_chunks
from tests.support.local_service import mgrao_command

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads peak memory from /proc")]

BUDGET_MIB = 256
BUDGET = BUDGET_MIB * 1024**2
TOLERANCE = 1.25


def _largest(build: Callable[[int], ExperimentSpec], low: int, high: int) -> int:
    """The largest size ``build`` accepts (binary search); the next size up is refused for memory."""
    while low < high:
        middle = (low + high + 1) // 2
        try:
            build(middle)
            low = middle
        except ConfigError:
            high = middle - 1
    return low


SHAPES: dict[str, tuple[Callable[[int], ExperimentSpec], int, int]] = {
    # many children and one group per parent: the learners' PW and trace dominate
    "learner state": (lambda x: make_spec("single", ["mgrao-max"], seeds=2, episodes=2, memory_budget=BUDGET,
                                          overrides={"n_parents": x, "n_composite_types": x, "n_types": 200,
                                                     "n_children": 100}), 1, 1000),
    # the oracle's expected values at many parents and long composites (drawn a block at a time, they
    # stay near 100 MiB even at the schema's largest system: the search ends at its limits)
    "oracle": (lambda x: make_spec("single", ["oracle"], seeds=2, episodes=2, memory_budget=BUDGET,
                                   overrides={"n_parents": x, "n_composite_types": min(x, 1000), "n_types": 200,
                                              "types_per_composite": 200}), 1, 3000),
    # a block's draws: churn with new profiles and routing among children
    "random draws": (lambda x: make_spec("volatile", ["uniform"], seeds=2, episodes=x, memory_budget=BUDGET,
                                         overrides={"n_parents": 1000, "n_composite_types": 1000, "n_children": 3,
                                                    "rejoin_profile": "new", "types_per_composite": 20,
                                                    "n_types": 200}), 1, 2000),
    # long runs of tiny systems: a chunk's utilities and their stored copies (two full chunks)
    "utilities": (lambda x: make_spec("single", ["uniform", "mgrao-1:1"], seeds=x, episodes=100_000,
                                      memory_budget=BUDGET, overrides={"n_parents": 1, "n_types": 2,
                                                                       "types_per_composite": 1,
                                                                       "n_composite_types": 1}), 1, 66),
}


def _status(pid: int, field: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) * 1024
    raise AssertionError(f"{field} not in /proc/{pid}/status")


def _wait(predicate: Callable[[], bool], timeout: float, what: str, process: subprocess.Popen, log: Path) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        if process.poll() is not None:
            raise AssertionError(f"the worker exited ({process.returncode}) waiting for {what}\n{log.read_text()}")
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what}\n{log.read_text()[-3000:]}")


@pytest.mark.parametrize("shape", list(SHAPES))
def test_largest_accepted_job_stays_within_the_budget(shape: str, tmp_path: Path) -> None:
    build, low, high = SHAPES[shape]
    size = _largest(build, low, high)
    spec = build(size)
    if size < high:
        with pytest.raises(WorkLimitError, match=f"budget of {BUDGET_MIB} MiB per chunk"):
            build(size + 1)
    estimate = max(chunk_cost(spec, len(chunk)).total for chunk in plan_chunks(spec, budget=BUDGET))
    assert estimate <= BUDGET

    url = f"sqlite:///{tmp_path / 'memory.db'}"
    db = Database(url)
    db.migrate()
    log = tmp_path / "worker.log"
    environment = dict(os.environ, MGRAO_DATABASE_URL=url, MGRAO_JOB_MEMORY_MIB=str(BUDGET_MIB),
                       MGRAO_POLL_S="0.05", MGRAO_HEARTBEAT_S="0.5")
    with log.open("wb") as output:
        worker = subprocess.Popen(mgrao_command("worker"), env=environment, stdout=output, stderr=output)
    try:
        _wait(lambda: "ready" in log.read_text(), 120, "the worker to warm up", worker, log)
        baseline = _status(worker.pid, "VmRSS")
        with db.write() as session:
            job_id = crud.create_job(session, spec=spec).id

        def finished() -> bool:
            with db.session() as session:
                job = session.get(Job, job_id)
                assert job.status not in ("failed", "cancelled"), job.error
                return job.status == "succeeded"

        _wait(finished, 600, f"the {shape} job", worker, log)
        used = _status(worker.pid, "VmHWM") - baseline
    finally:
        worker.terminate()
        worker.wait(timeout=30)
        db.dispose()
    print(f"{shape}: size {size}, estimate {estimate / 2**20:.0f} MiB, used {used / 2**20:.0f} MiB "
          f"above a baseline of {baseline / 2**20:.0f} MiB", file=sys.stderr)
    assert used <= TOLERANCE * BUDGET, f"{used / 2**20:.0f} MiB used for a {BUDGET_MIB} MiB budget"
