"""Helpers of the backend tests: real server and worker processes, and small utilities."""

from __future__ import annotations

import os
import re
import signal
import subprocess
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import httpx
from sqlalchemy import create_engine, event

from backend.execution.worker import Worker
from backend.store import crud
from backend.store.db import Database, alembic_config
from backend.store.models import CANCELLED, FAILED, SUCCEEDED
from mgrao_cli.supervisor import stop_processes
from tests.support.local_service import free_port, mgrao_command, serve_command, wait_healthy
from tests.support.waiting import wait_until

T = TypeVar("T")
ENDED = (SUCCEEDED, FAILED, CANCELLED)

TOKEN = "s3cret-token"
JSON = {"Content-Type": "application/json"}  # what a write without a body must still say
# The service answers only to allowed Host names (127.0.0.1 and localhost by default), so the
# in-process clients address it as 127.0.0.1 (TestClient's own default is "testserver").
BASE_URL = "http://127.0.0.1"


def drain(worker: Worker, most: int = 1000) -> int:
    """Run queued jobs until the queue is empty; the number run (more than ``most`` fails: it never empties)."""
    count = 0
    while ran := worker.run_once():  # a batch of small jobs counts each
        count += ran
        assert count <= most, f"the queue did not empty after {most} jobs run in a row"
    return count


# ---- real processes --------------------------------------------------------------------------


def children(pid: int) -> list[int]:
    """Child processes of ``pid`` (spawned from any of its threads), zombies included."""
    tasks = Path(f"/proc/{pid}/task").iterdir()
    return sorted(int(c) for task in tasks for c in (task / "children").read_text().split())


def alive(pid: int) -> bool:
    """``pid`` exists and is not a zombie (an orphan's zombie waits for whoever adopted it)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


def ready_workers(logs: str) -> set[int]:
    """Pids of the workers that logged ``worker HOST:PID ready``."""
    return {int(pid) for pid in re.findall(r"worker \S+:(\d+) ready", logs)}


class Service:
    """`mgrao serve` and `mgrao worker` processes on one database; stops what it starts."""

    def __init__(self, tmp_path: Path, db_url: str | None = None) -> None:
        self.tmp_path = tmp_path
        self.db_url = db_url or f"sqlite:///{tmp_path / 'service.db'}"
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        self.server: subprocess.Popen | None = None
        self.workers: list[subprocess.Popen] = []
        self.env = dict(os.environ, MGRAO_DATABASE_URL=self.db_url, MGRAO_STALE_AFTER_S="2",
                        MGRAO_HEARTBEAT_S="0.2", MGRAO_PROGRESS_S="0.1", MGRAO_POLL_S="0.05",
                        NUMBA_NUM_THREADS="1")
        self.env.pop("MGRAO_API_TOKEN", None)
        self._logs: list = []

    def _spawn(self, argv: list[str]) -> subprocess.Popen:
        log = open(self.tmp_path / f"proc-{len(self._logs)}.log", "wb")  # noqa: SIM115
        self._logs.append(log)
        return subprocess.Popen(argv, env=self.env, stdout=log, stderr=log)

    def start_server(self, workers: int = 0) -> None:
        self.server = self._spawn(serve_command(self.port, workers, self.db_url))
        try:
            wait_healthy(self.base, self.server)
        except RuntimeError as error:
            raise AssertionError(f"server did not start: {error}\n{self.logs(tail=3000)}") from None

    def start_worker(self) -> subprocess.Popen:
        process = self._spawn(mgrao_command("worker", "--database-url", self.db_url))
        self.workers.append(process)
        return process

    def kill_server(self) -> None:
        assert self.server is not None
        self.server.send_signal(signal.SIGKILL)
        self.server.wait()

    def stop(self) -> None:
        stop_processes([*self.workers, *([self.server] if self.server else [])], 30)
        for log in self._logs:
            log.close()

    def logs(self, tail: int | None = None) -> str:
        """Every process's log, whole: a check must not miss a line that later ones pushed out of a tail
        (the access log of a health poll every 50 ms fills kilobytes a second). ``tail``: only each
        log's last ``tail`` characters, for a failure's message."""
        texts = (p.read_text(errors="replace") for p in sorted(self.tmp_path.glob("proc-*.log")))
        return "\n".join(text if tail is None else text[-tail:] for text in texts)

    def get(self, path: str, **kwargs: object) -> httpx.Response:
        return httpx.get(self.base + path, timeout=30, **kwargs)

    def post(self, path: str, **kwargs: object) -> httpx.Response:
        return httpx.post(self.base + path, timeout=30, **kwargs)

    def wait_for(self, predicate: Callable[[], T], timeout: float = 90, what: str = "condition", *,
                 step: float = 0.1) -> T:
        """:func:`~tests.support.waiting.wait_until`, with the tail of each log if it times out."""
        return wait_until(predicate, timeout, what, step=step, details=lambda: self.logs(tail=3000))

    def wait_mid_job(self, job_id: int, condition: Callable[[dict], bool], what: str) -> dict:
        """Wait until the job (its ``GET /api/jobs/ID``), still queued or running, meets ``condition``: that answer.

        Fails at once if the job ended first: a test that kills or looks at a job mid-run needs work that outlasts
        its polls, and a job too short for it would otherwise wait out the whole deadline.
        """
        def mid_job() -> dict | None:
            state = self.get(f"/api/jobs/{job_id}").json()
            if state["status"] in ENDED:
                raise AssertionError(f"job {job_id} ended ({state['status']}) before {what}: its work is too short "
                                     "for a test that acts on it mid-run")
            return state if condition(state) else None

        return self.wait_for(mid_job, what=what)



def alembic_to(db_url: str, action: Callable[[Any, str], None], revision: str) -> None:
    """Run alembic's ``action`` (``command.upgrade`` or ``command.downgrade``) to ``revision`` on ``db_url``."""
    engine = create_engine(db_url)
    config = alembic_config()
    with engine.connect() as connection:
        config.attributes["connection"] = connection
        action(config, revision)
        connection.commit()
    engine.dispose()


def listing_statements(db: Database, containing: str = "ORDER BY", **listing: Any) -> list[tuple[str, Any]]:
    """The SQL and parameters of each statement containing ``containing`` that crud.list_jobs runs for ``listing``."""
    seen: list[tuple[str, Any]] = []

    def capture(_conn: Any, _cursor: Any, statement: str, parameters: Any, _context: Any, _many: bool) -> None:
        if containing in statement:
            seen.append((statement, parameters))

    event.listen(db.engine, "before_cursor_execute", capture)
    try:
        with db.session() as session:
            crud.list_jobs(session, **listing)
    finally:
        event.remove(db.engine, "before_cursor_execute", capture)
    return seen
