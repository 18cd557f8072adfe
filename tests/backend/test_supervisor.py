"""``mgrao serve`` with real processes: worker restarts, backoff, orphans, working directory, busy port."""

from __future__ import annotations

import os
import re
import signal
import site
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from backend_helpers import Service, alive, children, ready_workers

from mgrao_cli.supervisor import Backoff
from tests.support.local_service import serve_command, wait_healthy

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]

JOB = {"system": "single", "seeds": 1, "episodes": 10}


def test_the_backoff_doubles_per_quick_death_up_to_its_cap() -> None:
    assert [Backoff().delay(n) for n in range(1, 9)] == [1, 2, 4, 8, 16, 30, 30, 30]
    assert Backoff(first_s=0.5, cap_s=3).delay(10_000) == 3


def run_a_job(service: Service) -> None:
    response = service.post("/api/jobs", json=JOB)
    assert response.status_code == 202
    job_id = response.json()["id"]
    service.wait_for(lambda: service.get(f"/api/jobs/{job_id}").json()["status"] == "succeeded",
                     timeout=60, what="a job to run")


def workers_of(service: Service, count: int, *, other_than: set[int] = frozenset()) -> list[int]:
    """Wait until serve has ``count`` live workers, none of them in ``other_than``; their pids."""
    assert service.server is not None
    server = service.server.pid

    def replaced() -> bool:
        pids = [p for p in children(server) if alive(p)]
        return len(pids) == count and not set(pids) & other_than

    service.wait_for(replaced, timeout=60, what=f"{count} worker(s) other than {sorted(other_than)}")
    return [p for p in children(server) if alive(p)]


def test_workers_killed_by_sigkill_sigsegv_and_sigbus_are_logged_and_restarted(service: Service) -> None:
    service.start_server(workers=2)
    first = workers_of(service, 2)
    os.kill(first[0], signal.SIGKILL)
    os.kill(first[1], signal.SIGSEGV)
    second = workers_of(service, 2, other_than=set(first))
    os.kill(second[0], signal.SIGBUS)
    workers_of(service, 2, other_than={*first, second[0]})
    logs = service.logs()
    assert f"worker {first[0]} was killed by SIGKILL" in logs
    assert f"worker {first[1]} was killed by SIGSEGV" in logs
    assert f"worker {second[0]} was killed by SIGBUS" in logs
    assert service.get("/api/health").status_code == 200
    run_a_job(service)


def test_a_worker_that_keeps_dying_is_restarted_after_growing_delays_while_the_api_serves(
        service: Service) -> None:
    service.start_server(workers=1)
    (pid,) = workers_of(service, 1)
    killed_pids, gaps = [], []
    for _ in range(3):
        os.kill(pid, signal.SIGKILL)
        killed = time.monotonic()

        def restarted(dead: int = pid) -> list[int]:
            assert service.get("/api/health").status_code == 200  # the API serves during the backoff
            return [p for p in children(service.server.pid) if alive(p) and p != dead]

        pids = service.wait_for(restarted, timeout=60, what=f"a worker in place of {pid}", step=0.05)
        gaps.append(time.monotonic() - killed)
        killed_pids.append(pid)
        (pid,) = pids
    # delays of 1, 2 and 4 s: each restart waited at least its delay, and the supervisor says which
    # delay it chose (how much longer a restart took depends on the machine's load, not on the backoff)
    assert gaps[0] >= 0.9 and gaps[1] >= 1.9 and gaps[2] >= 3.9, gaps
    logs = service.logs()
    for dead, delay in zip(killed_pids, [1, 2, 4], strict=True):
        assert re.search(rf"worker {dead} was killed by SIGKILL after [0-9.]+ s; restarting it in {delay} s\n", logs), \
            f"no restart of {dead} after {delay} s in the log\n{service.logs(tail=3000)}"
    run_a_job(service)


def test_the_supervisor_keeps_restarting_workers_after_its_stderr_broke(service: Service) -> None:
    process = subprocess.Popen(serve_command(service.port, 1, service.db_url), env=service.env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    service.server = process  # stopped by pid at the end of the test
    wait_healthy(service.base, process)
    (pid,) = workers_of(service, 1)
    assert process.stdout is not None
    process.stdout.close()  # like `mgrao serve 2>&1 | tee log` after tee died: every write to stderr fails
    os.kill(pid, signal.SIGKILL)
    (pid,) = workers_of(service, 1, other_than={pid})
    os.kill(pid, signal.SIGKILL)  # the watcher is still there for a second death
    workers_of(service, 1, other_than={pid})
    run_a_job(service)


def test_a_worker_that_cannot_be_started_is_retried_while_the_api_serves(service: Service,
                                                                        tmp_path: Path) -> None:
    venv = tmp_path / "venv"  # serve runs from an interpreter path that the test can take away
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    python = venv / "bin" / "python"
    service.env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *site.getsitepackages()])
    argv = serve_command(service.port, 1, service.db_url)
    service.server = service._spawn([str(python), *argv[1:]])
    wait_healthy(service.base, service.server)
    (pid,) = workers_of(service, 1)
    python.rename(python.with_name("python-away"))  # e.g. the virtualenv is being rebuilt
    os.kill(pid, signal.SIGKILL)
    service.wait_for(lambda: service.logs().count("could not start a worker") >= 2, timeout=30,
                     what="two failed starts")
    assert "trying again in 2 s" in service.logs()
    assert service.get("/api/health").status_code == 200
    python.with_name("python-away").rename(python)
    workers_of(service, 1, other_than={pid})
    run_a_job(service)


def test_workers_exit_when_serve_is_killed_and_a_restart_starts_exactly_n(service: Service) -> None:
    service.start_server(workers=2)
    pids = workers_of(service, 2)
    service.wait_for(lambda: ready_workers(service.logs()) >= set(pids), what="both workers ready")
    service.kill_server()
    try:  # each notices within half a second and stops; the deadline is for a loaded machine
        service.wait_for(lambda: not any(alive(p) for p in pids), timeout=30,
                         what="the workers of a killed serve to exit (orphans otherwise)")
    finally:
        for pid in pids:  # whatever happened, leave no orphan behind
            if alive(pid):
                os.kill(pid, signal.SIGKILL)

    service.start_server(workers=2)
    again = workers_of(service, 2)
    service.wait_for(lambda: ready_workers(service.logs()) >= set(again), what="the new workers ready")
    assert sorted(worker_processes_on(service.db_url)) == sorted(again)


def worker_processes_on(database_url: str) -> list[int]:
    """Every live ``backend.processes`` process on this machine whose database is ``database_url``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
            environ = (entry / "environ").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"backend.processes" in argv and f"MGRAO_DATABASE_URL={database_url}".encode() in environ:
            if alive(int(entry.name)):
                found.append(int(entry.name))
    return found


def test_workers_run_the_served_code_not_a_package_in_the_working_directory(service: Service,
                                                                            tmp_path: Path) -> None:
    decoy = tmp_path / "checkout"
    for package in ["backend", "mgrao_core"]:
        (decoy / package).mkdir(parents=True)
        (decoy / package / "__init__.py").write_text(f"raise ImportError('decoy {package} imported')\n")
    argv = serve_command(service.port, 2, service.db_url)
    argv.insert(1, "-P")  # as the `mgrao` script runs: the working directory is not on serve's sys.path
    log = open(tmp_path / "proc-decoy.log", "wb")  # noqa: SIM115 (closed below)
    try:
        service.server = subprocess.Popen(argv, cwd=decoy, env=service.env, stdout=log, stderr=log)
        wait_healthy(service.base, service.server)
        run_a_job(service)
    finally:
        log.close()
    assert "decoy" not in service.logs()


def test_serve_on_a_busy_port_fails_first_and_starts_no_worker(tmp_path: Path) -> None:
    database = tmp_path / "busy.db"
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = subprocess.run(serve_command(port, 2, f"sqlite:///{database}"), capture_output=True, text=True,
                                timeout=60, check=False, env=dict(os.environ, MGRAO_POLL_S="0.05"))
    assert result.returncode != 0
    assert f"port {port} on 127.0.0.1 is in use" in result.stderr
    assert "http://" not in result.stderr + result.stdout  # no URL printed for a server that never ran
    assert "worker" not in result.stderr
    assert not database.exists()  # failed before migrating, before starting anything


def test_serve_on_port_0_prints_the_port_it_listens_on(service: Service) -> None:
    service.server = service._spawn(serve_command(0, 0, service.db_url))
    service.wait_for(lambda: "mgrao: http://" in service.logs(), timeout=60, what="the URL")
    url = next(w for w in service.logs().split() if w.startswith("http://127.0.0.1:"))
    assert not url.endswith(":0/")
    wait_healthy(url.rstrip("/"), service.server)


def test_serves_accepted_connections_without_nagle_delay() -> None:
    """The socket ``serve`` hands uvicorn makes asyncio set TCP_NODELAY on each connection it accepts.

    Without it a keep-alive client waited for its own delayed ACK (about 40 ms) on every request,
    between the response's header and body writes: 48 ms for /api/health instead of 3.
    """
    import asyncio

    from mgrao_cli.service_commands import listen

    async def nodelay_of_an_accepted_connection() -> int:
        seen: asyncio.Future[int] = asyncio.get_running_loop().create_future()

        def accepted(_reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            sock = writer.get_extra_info("socket")
            seen.set_result(sock.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY))
            writer.close()

        server = await asyncio.start_server(accepted, sock=listen("127.0.0.1", 0))
        try:
            port = server.sockets[0].getsockname()[1]
            _reader, writer = await asyncio.open_connection("127.0.0.1", port)
            try:
                return await asyncio.wait_for(seen, timeout=10)  # deadline: the connection was accepted
            finally:
                writer.close()
        finally:
            server.close()

    assert asyncio.run(nodelay_of_an_accepted_connection()) != 0


def test_a_dead_workers_jobs_are_handed_back_at_once_and_each_stored_exactly_once(service: Service) -> None:
    """Issue 30, point 14: serve's supervisor sees its worker die and re-queues what it held at once, long
    before the heartbeats go stale (300 s here): a batch of small jobs and a job that runs alone."""
    from sqlalchemy import bindparam, create_engine, text

    service.env["MGRAO_STALE_AFTER_S"] = "300"
    service.start_server(workers=1)
    [worker] = workers_of(service, 1)
    # small jobs (batched), about 0.3 s in all: the worker is killed while it runs them, not after it stored them
    small = {"system": "single", "seeds": 2, "episodes": 1000, "algorithms": ["uniform", "mgrao-max"]}
    ids = [service.post("/api/jobs", json=small).json()["id"] for _ in range(40)]
    alone = {"system": "large", "seeds": 40, "episodes": 2000, "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"]}
    ids.append(service.post("/api/jobs", json=alone).json()["id"])
    engine = create_engine(service.db_url)

    def held() -> list[int]:
        with engine.connect() as connection:
            return list(connection.execute(text("SELECT id FROM jobs WHERE status = 'running' AND worker_id = :w"),
                                           {"w": f"{socket.gethostname()}:{worker}"}).scalars())

    taken = service.wait_for(held, timeout=120, what=f"worker {worker} to hold jobs", step=0.02)
    os.kill(worker, signal.SIGKILL)
    killed_at = time.monotonic()
    service.wait_for(lambda: f"worker {worker}'s jobs" in service.logs(), timeout=30,
                     what="the supervisor to hand back the dead worker's jobs")
    with engine.connect() as connection:
        reasons = dict(connection.execute(text("SELECT id, requeue_reason FROM jobs WHERE id IN :ids")
                                          .bindparams(bindparam("ids", expanding=True)), {"ids": taken}).all())
    # each job it held goes back saying why (one it finished in the instant before it died has no reason)
    assert set(reasons.values()) <= {f"worker {socket.gethostname()}:{worker} was killed by SIGKILL", None}, reasons
    assert any(reasons.values()), reasons
    service.wait_for(lambda: all(service.get(f"/api/jobs/{i}").json()["status"] == "succeeded" for i in ids),
                     timeout=240, what="every job to succeed after the hand-back")
    assert time.monotonic() - killed_at < 240  # not the 300 s of stale heartbeats
    with engine.connect() as connection:
        counts = dict(connection.execute(text("SELECT job_id, count(*) FROM runs GROUP BY job_id")).all())
    engine.dispose()
    assert counts == {i: (2 * 2 if i != ids[-1] else 40 * 3) for i in ids}  # every run stored, once

