"""The dispatcher on a real Dask cluster and a real PostgreSQL server, with faults.

Every test runs the topology of a cluster deployment as local processes on 127.0.0.1: a
PostgreSQL server (started by the session), ``dask scheduler``, ``dask worker`` processes and
``mgrao dispatcher`` (and, for the end-to-end test, ``mgrao serve --workers 0``). After each
fault it checks that every run of every job is stored exactly once and equals, bit for bit, the
same simulation in one process.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import large_job
import numpy as np
import pytest
from backend_helpers import ENDED
from sqlalchemy import func, select

from backend.store import crud
from backend.store.db import Database
from backend.store.models import CANCELLED, FAILED, SUCCEEDED, Job, Run
from mgrao_core import ExperimentSpec, make_spec, run_experiment
from tests.support.dask_cluster import DaskCluster
from tests.support.local_service import free_port, mgrao_command, serve_command, stop, wait_healthy
from tests.support.waiting import wait_until

pytestmark = pytest.mark.slow

FAST = {"MGRAO_POLL_S": "0.1", "MGRAO_HEARTBEAT_S": "0.5", "MGRAO_PROGRESS_S": "0.2", "MGRAO_STALE_AFTER_S": "4"}


@pytest.fixture
def pg_url(postgres_server) -> Iterator[str]:
    url = postgres_server.create_database()
    db = Database(url)
    db.migrate()
    db.dispose()
    yield url
    postgres_server.drop_database(url)


class Topology:
    """The processes of one test, stopped by process id at the end."""

    def __init__(self, tmp_path: Path, url: str, scheduler_env: dict[str, str] | None = None) -> None:
        self.tmp_path, self.url = tmp_path, url
        self.cluster = DaskCluster(tmp_path, scheduler_env)
        self.dispatchers: list[subprocess.Popen] = []
        self.db = Database(url)
        self._logs: list = []

    def start_cluster(self, workers: int = 2, **worker_options) -> None:
        self.cluster.start_scheduler()
        for _ in range(workers):
            self.cluster.start_worker(**worker_options)
        self.cluster.wait_workers(workers)

    def start_dispatcher(self, **env: str) -> subprocess.Popen:
        log = open(self.tmp_path / f"dispatcher-{len(self.dispatchers)}.log", "wb")  # noqa: SIM115
        self._logs.append(log)
        environment = dict(os.environ, MGRAO_DATABASE_URL=self.url, **FAST, **env)
        process = subprocess.Popen(mgrao_command("dispatcher", "--dask", self.cluster.address), env=environment,
                                   stdout=log, stderr=subprocess.STDOUT)
        self.dispatchers.append(process)
        return process

    def submit(self, spec: ExperimentSpec) -> int:
        with self.db.write() as session:
            return crud.create_job(session, spec=spec).id

    def job(self, job_id: int) -> Job:
        with self.db.session() as session:
            return session.get(Job, job_id)

    def wait(self, job_id: int, status: str = "succeeded", timeout: float = 240) -> Job:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            job = self.job(job_id)
            if job.status == status:
                return job
            if job.status in ("succeeded", "failed", "cancelled") and job.status != status:
                raise AssertionError(f"job {job_id} is {job.status}: {job.error}\n{self.logs()}")
            time.sleep(0.2)
        raise AssertionError(f"job {job_id} is {self.job(job_id).status} after {timeout} s\n{self.logs()}")

    def wait_for(self, predicate, what: str, timeout: float = 120, step: float = 0.1):
        return wait_until(predicate, timeout, what, step=step, details=self.logs)

    def wait_mid_job(self, job_id: int, condition, what: str) -> Job:
        """Wait until the job, still queued or running, meets ``condition`` (given its row); fail at once if it
        ended first (a test that kills its dispatcher mid-job needs work that outlasts its polls)."""
        def mid_job() -> Job | None:
            job = self.job(job_id)
            if job.status in ENDED:
                raise AssertionError(f"job {job_id} ended ({job.status}) before {what}: its work is too short for a "
                                     f"test that acts on it mid-run; {job.stopped or ''}")
            return job if condition(job) else None

        return self.wait_for(mid_job, what)

    def finished(self, job_id: int) -> bool:
        """The job succeeded (False while it is queued or running; any other end fails the test)."""
        job = self.job(job_id)
        if job.status in (FAILED, CANCELLED):
            raise AssertionError(f"job {job_id} is {job.status}: {job.error}\n{self.logs()}")
        return job.status == SUCCEEDED

    def stored_seeds(self, job_id: int) -> int:
        with self.db.session() as session:
            return session.scalar(select(func.count(func.distinct(Run.seed))).where(Run.job_id == job_id)) or 0

    def assert_stored_exactly_once(self, job_id: int, spec: ExperimentSpec) -> dict[tuple[str, int], int]:
        """Every run of the job stored once, bit-identical to one process; the rows' ids by run."""
        expected = {(r.algorithm, r.seed): r for r in run_experiment(spec).runs}
        with self.db.session() as session:
            runs = session.scalars(select(Run).where(Run.job_id == job_id)).all()
        assert len(runs) == len(expected)
        assert {(r.algorithm, r.seed) for r in runs} == set(expected)
        for run in runs:
            want = expected[(run.algorithm, run.seed)]
            assert np.frombuffer(run.utilities, dtype="<f8").tobytes() == want.utilities.tobytes()
            assert np.frombuffer(run.combined_weights, dtype="<f8").tobytes() == want.combined_weights.tobytes()
        return {(r.algorithm, r.seed): r.id for r in runs}

    def logs(self) -> str:
        return self.cluster.logs() + "\n".join(
            p.read_text(errors="replace")[-3000:] for p in sorted(self.tmp_path.glob("dispatcher-*.log")))

    def stop(self) -> None:
        for process in self.dispatchers:
            stop(process, timeout=20)
        self.cluster.stop()
        for log in self._logs:
            log.close()
        self.db.dispose()


@pytest.fixture
def topology(tmp_path: Path, pg_url: str) -> Iterator[Topology]:
    setup = Topology(tmp_path, pg_url)
    yield setup
    setup.stop()


def _big() -> ExperimentSpec:
    return make_spec("large", seeds=24, episodes=600)


def test_the_cluster_topology_end_to_end_over_rest(tmp_path: Path, topology: Topology) -> None:
    topology.start_cluster(workers=2)
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")}
    with open(tmp_path / "serve.log", "wb") as log:
        server = subprocess.Popen(serve_command(port, 0, topology.url), env=env, stdout=log, stderr=subprocess.STDOUT)
    try:
        base = f"http://127.0.0.1:{port}"
        wait_healthy(base, server)
        topology.start_dispatcher()
        bodies = [{"system": "single", "seeds": 6, "episodes": 100},
                  {"system": "multi", "seeds": [3, 9, 27], "episodes": 60,
                   "algorithms": ["uniform", "oracle", "mgrao-2:1", "mgrao-max"]},
                  {"system": "volatile", "seeds": 4, "episodes": 80, "params": {"absent_tasks": "counted"}},
                  {"system": "large", "seeds": 5, "episodes": 100}]
        ids = [httpx.post(f"{base}/api/jobs", json=body, timeout=30).json()["id"] for body in bodies]
        for job_id, body in zip(ids, bodies, strict=True):
            topology.wait(job_id)
            spec = make_spec(body["system"], body.get("algorithms"), body["seeds"], body["episodes"],
                             body.get("params"))
            topology.assert_stored_exactly_once(job_id, spec)
            results = httpx.get(f"{base}/api/jobs/{job_id}/results", timeout=30).json()
            assert results["partial"] is False
            assert topology.job(job_id).worker_id.startswith("dispatcher:")
    finally:
        stop(server)


def test_a_job_of_10000_children_on_the_cluster_stores_what_a_local_worker_stores(topology: Topology) -> None:
    # issue 42, item 4: each Dask task sends back its runs as stored (the learner's PW of its first 1,000 children,
    # 16 MB, not 160 MB), and the dispatcher stores them as a local worker does, bit for bit the core's
    topology.start_cluster(workers=1)
    topology.start_dispatcher()
    job_id = topology.submit(make_spec("multi", large_job.ALGORITHMS, large_job.SEEDS, large_job.EPISODES,
                                       large_job.PARAMS))
    assert topology.wait(job_id, timeout=600).worker_id.startswith("dispatcher:")
    large_job.assert_stored_within_bounds(topology.db, job_id)


def test_at_most_threads_plus_margin_chunks_in_flight(topology: Topology) -> None:
    from distributed import Client

    from backend.execution.dispatcher import IN_FLIGHT_MARGIN

    topology.start_cluster(workers=2)
    topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")  # many small chunks
    job_ids = [topology.submit(make_spec("large", seeds=30, episodes=300)) for _ in range(2)]
    most = 0
    with Client(topology.cluster.address, timeout=30, set_as_default=False) as client:
        def both_done() -> bool:
            nonlocal most
            keys = client.run_on_scheduler(lambda dask_scheduler: [
                k for k, t in dask_scheduler.tasks.items() if str(k).startswith("mgrao-") and t.state != "memory"])
            most = max(most, len(keys))
            return all(topology.finished(job_id) for job_id in job_ids)

        topology.wait_for(both_done, "both jobs to succeed (chunks in flight sampled meanwhile)", timeout=300,
                          step=0.05)
    assert 0 < most <= 2 + IN_FLIGHT_MARGIN
    for job_id in job_ids:
        topology.assert_stored_exactly_once(job_id, make_spec("large", seeds=30, episodes=300))


def test_a_dask_worker_killed_mid_job(topology: Topology) -> None:
    topology.start_cluster(workers=2)
    topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")
    job_id = topology.submit(_big())
    topology.wait_for(lambda: topology.stored_seeds(job_id) > 0, "the first stored chunk")
    victim = topology.cluster.worker_pids()[0]
    os.kill(victim, signal.SIGKILL)
    topology.wait(job_id)
    topology.assert_stored_exactly_once(job_id, _big())


def test_a_dask_worker_frozen_mid_job(tmp_path: Path, pg_url: str) -> None:
    # the scheduler checks its workers' heartbeats every worker-ttl, and drops one silent for the ttl or 10
    # heartbeats (5 s on a small cluster), whichever is longer: 1 s checks every second, and drops it after 5 s
    setup = Topology(tmp_path, pg_url, scheduler_env={"DASK_DISTRIBUTED__SCHEDULER__WORKER_TTL": "1s"})
    frozen = None
    try:
        setup.start_cluster(workers=2)
        setup.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")
        job_id = setup.submit(_big())
        setup.wait_for(lambda: setup.stored_seeds(job_id) > 0, "the first stored chunk")
        frozen = setup.cluster.worker_pids()[0]
        os.kill(frozen, signal.SIGSTOP)  # its heartbeats stop: the scheduler drops it after the ttl
        setup.wait(job_id)
        setup.assert_stored_exactly_once(job_id, _big())
    finally:
        if frozen is not None:
            try:
                os.kill(frozen, signal.SIGCONT)
            except ProcessLookupError:  # its nanny replaced it meanwhile
                pass
        setup.stop()


def test_a_chunk_that_kills_its_worker_every_time_fails_its_job_only(tmp_path: Path, pg_url: str) -> None:
    # the workers' memory limit is below what one chunk of the big job needs: the nanny kills
    # every worker that runs it; after the allowed failures the job fails and the others finish
    setup = Topology(tmp_path, pg_url, scheduler_env={"DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES": "1"})
    try:
        setup.start_cluster(workers=2, memory_limit="600MB")
        setup.start_dispatcher(MGRAO_JOB_MEMORY_MIB="4096")
        hog = make_spec("single", ["mgrao-max", "mgrao-250:1", "mgrao-125:1"], seeds=2, episodes=40,
                        overrides={"n_parents": 500, "n_composite_types": 500, "n_types": 200, "n_children": 100},
                        memory_budget=4096 * 1024**2)
        hog_id = setup.submit(hog)
        small = make_spec("single", seeds=4, episodes=50)
        small_id = setup.submit(small)
        failed = setup.wait(hog_id, "failed")
        assert "killed every Dask worker that ran it" in failed.error
        setup.wait(small_id)
        setup.assert_stored_exactly_once(small_id, small)
    finally:
        setup.stop()


def test_the_scheduler_restarted_mid_job(topology: Topology) -> None:
    topology.start_cluster(workers=2)
    topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")
    job_id = topology.submit(_big())
    topology.wait_for(lambda: topology.stored_seeds(job_id) > 0, "the first stored chunk")
    topology.cluster.restart_scheduler()
    topology.wait(job_id)
    topology.assert_stored_exactly_once(job_id, _big())


def test_the_dispatcher_killed_mid_job_and_its_successor_resumes(topology: Topology) -> None:
    topology.start_cluster(workers=2)
    first = topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")
    big = make_spec("large", seeds=72, episodes=600)  # 11 chunks: more than a second left after the first
    job_id = topology.submit(big)

    topology.wait_mid_job(job_id, lambda _: topology.stored_seeds(job_id) >= 4, "a few stored chunks")
    first.send_signal(signal.SIGKILL)
    first.wait()
    with topology.db.session() as session:
        kept = {(r.algorithm, r.seed): r.id for r in session.scalars(select(Run).where(Run.job_id == job_id))}
    assert 0 < len(kept) < len(big.seeds) * 7
    topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")
    job = topology.wait(job_id)
    assert job.attempts == 2 and "re-queued" not in (job.error or "")
    ids = topology.assert_stored_exactly_once(job_id, big)
    assert all(ids[key] == row_id for key, row_id in kept.items())  # the stored chunks were not redone


def test_cancelling_a_job_cancels_its_futures_and_keeps_its_chunks(topology: Topology) -> None:
    from distributed import Client

    topology.start_cluster(workers=2)
    topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")
    long = make_spec("large", seeds=24, episodes=3000)  # seconds of chunks left when the cancel lands
    job_id = topology.submit(long)
    topology.wait_for(lambda: topology.stored_seeds(job_id) > 0, "the first stored chunk")
    with topology.db.write() as session:
        crud.cancel_job(session, job_id=job_id)
    stored = topology.stored_seeds(job_id)

    with Client(topology.cluster.address, timeout=30, set_as_default=False) as client:
        def ours() -> list[str]:
            return client.run_on_scheduler(lambda dask_scheduler: [
                str(k) for k in dask_scheduler.tasks if str(k).startswith(f"mgrao-{job_id}-")])

        topology.wait_for(lambda: not ours(), "the job's futures to be cancelled", timeout=30)
    time.sleep(1)
    assert topology.job(job_id).status == "cancelled"
    assert stored <= topology.stored_seeds(job_id) < len(long.seeds)  # partial, and no more after the cancel
    after = make_spec("single", seeds=3, episodes=40)
    after_id = topology.submit(after)
    topology.wait(after_id)  # the dispatcher goes on with other jobs
    topology.assert_stored_exactly_once(after_id, after)


def test_a_job_with_a_stopping_rule_runs_block_by_block_and_its_successor_resumes(topology: Topology) -> None:
    """A rule's blocks on the cluster (each block several chunks), the dispatcher killed between them: the same
    verdicts and seeds as the rule run in one process, every run of the seeds judged stored once."""
    from mgrao_core.statistics.sequential import run_until, stopped_dict, until_spec

    rule = {"half_width": 0.05, "block": 4, "max_seeds": 48}  # undecided to 48 seeds: blocks left at the kill
    spec, until = until_spec("large", None, 7, 300, {}, rule)
    topology.start_cluster(workers=2)
    first = topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")  # several chunks a block
    with topology.db.write() as session:
        job_id = crud.create_job(session, spec=spec, until=until).id
    topology.wait_mid_job(job_id, lambda job: (job.stopped or {}).get("seeds", 0) >= 8, "two blocks judged")
    first.send_signal(signal.SIGKILL)
    first.wait()
    topology.start_dispatcher(MGRAO_JOB_MEMORY_MIB="16")
    job = topology.wait(job_id)
    expected = run_until(spec, until, run_experiment)
    assert job.attempts == 2 and job.stopped == stopped_dict(expected.blocks, until.as_dict())
    assert job.config["seeds"] == list(expected.result.spec.seeds)
    topology.assert_stored_exactly_once(job_id, expected.result.spec)
