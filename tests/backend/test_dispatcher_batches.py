"""Small jobs in batches on Dask (issue 23): the dispatcher claims them together and runs each batch as one task.

Real ``dask scheduler``, ``dask worker`` and ``mgrao dispatcher`` processes, on SQLite and PostgreSQL;
the dispatcher is killed with SIGKILL in the middle of a batch; every wait has a deadline.
"""

from __future__ import annotations

import pickle
import re
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
from test_batches import SMALL, _in_flight_after_kill, _jobs, assert_each_ran_once
from test_dispatcher import Topology

from backend.execution.dask_tasks import simulate_batch
from backend.execution.failures import Failure
from backend.execution.small_jobs import BATCH_BYTES, packed, run_bytes
from backend.store.db import Database
from backend.store.queue import Claim
from mgrao_core import make_spec

pytestmark = pytest.mark.slow

BATCH_LOG = re.compile(r"dispatcher \S+ runs a batch of (\d+) jobs")


@pytest.fixture
def topology(tmp_path: Path, db_url: str) -> Iterator[Topology]:
    db = Database(db_url)
    db.migrate()
    db.dispose()
    setup = Topology(tmp_path, db_url)
    yield setup
    setup.stop()


def _small():  # noqa: ANN202
    return make_spec(SMALL["system"], SMALL["algorithms"], SMALL["seeds"], SMALL["episodes"])


def _submit(topology: Topology, count: int) -> list[int]:
    return [topology.submit(_small()) for _ in range(count)]


def _dispatcher_logs(topology: Topology) -> str:
    return "".join(p.read_text(errors="replace") for p in sorted(topology.tmp_path.glob("dispatcher-*.log")))


def _succeeded(url: str) -> int:
    return sum(job.status == "succeeded" for job in _jobs(url))


def test_small_jobs_run_in_batches_on_dask_with_a_local_workers_numbers(topology: Topology, db_url: str) -> None:
    ids = _submit(topology, 40)
    topology.start_cluster(workers=2)
    topology.start_dispatcher()
    topology.wait_for(lambda: _succeeded(db_url) == len(ids), "every small job succeeded", timeout=180)
    sizes = [int(size) for size in BATCH_LOG.findall(_dispatcher_logs(topology))]
    assert sum(sizes) == len(ids) and max(sizes) > 1, sizes  # claimed and run in batches, each job once
    jobs = _jobs(db_url)
    assert {job.attempts for job in jobs} == {1} and all(job.worker_id.startswith("dispatcher:") for job in jobs)
    spec = _small()  # the numbers a local worker stores (one process: run_experiment)
    for job_id in ids:
        topology.assert_stored_exactly_once(job_id, spec)


def test_the_dispatcher_killed_in_the_middle_of_a_batch_leaves_every_job_run_once(topology: Topology,
                                                                                   db_url: str) -> None:
    ids = _submit(topology, 150)
    topology.start_cluster(workers=2)
    victim = topology.start_dispatcher()
    topology.wait_for(lambda: BATCH_LOG.search(_dispatcher_logs(topology)) and sum(
        job.status == "running" for job in _jobs(db_url)) >= 10, "a batch claimed and sent (logged)", step=0.02)
    victim.send_signal(signal.SIGKILL)
    victim.wait()
    in_flight = _in_flight_after_kill(db_url)
    assert len(in_flight) >= 10, "the dispatcher was not killed in the middle of a batch"

    topology.start_dispatcher()  # re-queues the dead dispatcher's jobs once their heartbeats are stale (4 s)
    topology.wait_for(lambda: _succeeded(db_url) == len(ids), "every job succeeded", timeout=240)
    assert_each_ran_once(db_url, ids, in_flight)


@pytest.mark.parametrize(("seeds", "sizes"), [([1, 1, 1], [3]), ([1, 40, 1, 1, 40, 40, 1], [1, 1, 2, 1, 1, 1]),
                                              ([40] * 3, [1, 1, 1])])
def test_a_claimed_batch_is_cut_into_dask_tasks_within_the_memory_bound(seeds: list[int], sizes: list[int]) -> None:
    """``packed`` keeps the claim order and every job once; a task's runs stay within the bound, or it is one job."""
    specs = {job_id: make_spec("large", ["uniform", "mgrao-max"], count, 50) for job_id, count in enumerate(seeds)}
    claims = [Claim(job_id, "lease", {}, 1) for job_id in specs]
    one, forty = (run_bytes(make_spec("large", ["uniform", "mgrao-max"], count, 50)) for count in (1, 40))
    assert forty > 4 * one
    limit = 2 * one + forty // 2  # two one-seed jobs fit beside each other, a forty-seed one with nothing
    parts = packed(claims, specs, limit=limit)
    assert [claim for part in parts for claim in part] == claims
    assert [len(part) for part in parts] == sizes
    for part in parts:
        assert len(part) == 1 or sum(run_bytes(specs[claim.job_id]) for claim in part) <= limit, part


def test_the_default_bound_packs_the_benchmarks_small_jobs_into_one_task() -> None:
    specs = {job_id: _small() for job_id in range(64)}
    claims = [Claim(job_id, "lease", {}, 1) for job_id in specs]
    assert packed(claims, specs) == [claims]  # the default claim (MGRAO_BATCH_JOBS) is one task
    assert 64 * run_bytes(_small()) <= BATCH_BYTES


def test_a_batch_task_returns_a_jobs_error_as_its_picklable_failure_and_runs_the_others() -> None:
    """One job's error fails that job only, mapped where it happened (a ConfigError does not pickle)."""
    jobs = [(1, {"system": "no-such-system", "seeds": 1, "episodes": 2}, [[0]]), (2, _small().as_dict(), [[0]])]
    results = pickle.loads(pickle.dumps(simulate_batch(jobs, memory_budget=256 * 1024**2)))
    assert [job_id for job_id, _ in results] == [1, 2]
    assert isinstance(results[0][1], Failure) and "no-such-system" in results[0][1].message
    assert not results[0][1].message.startswith("ConfigError")  # the core's own message, as a local worker stores
    assert len(results[1][1]) == len(_small().algorithms)  # the other job ran: one run per algorithm (seed 0)
