"""Fixtures: a real database per test (a SQLite file, and a database on a real PostgreSQL server that
the session starts and stops), the app in-process, and real server/worker processes.

Every test that takes ``db_url`` (directly or through ``settings``, ``client``, ``worker``, ``db`` or
``service``) runs twice, ``[sqlite]`` and ``[postgresql]``; the PostgreSQL runs skip, saying why,
only where no PostgreSQL server can be started (see tests/support/postgres.py).
"""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from backend_helpers import BASE_URL, TOKEN, Service
from fastapi.testclient import TestClient

from backend.api.app import create_app
from backend.execution.worker import Worker
from backend.processes import local_worker
from backend.settings import Settings
from backend.store.db import Database
from tests.support.local_service import free_port, serve_command, stop, wait_healthy
from tests.support.postgres import PostgresServer, throwaway_server


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    with throwaway_server() as server:
        yield server


@pytest.fixture(params=["sqlite", "postgresql"])
def db_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'mgrao.db'}"
        return
    server: PostgresServer = request.getfixturevalue("postgres_server")
    url = server.create_database()
    yield url
    server.drop_database(url)


@pytest.fixture
def settings(db_url: str) -> Settings:
    return Settings(database_url=db_url, stale_after_s=2, heartbeat_s=0.2, progress_s=0.1, poll_s=0.05)


@pytest.fixture
def client(settings: Settings) -> Iterator[TestClient]:
    with TestClient(create_app(settings), base_url=BASE_URL) as test_client:
        yield test_client


@pytest.fixture
def auth_client(settings: Settings) -> Iterator[TestClient]:
    with TestClient(create_app(settings.model_copy(update={"api_token": TOKEN})), base_url=BASE_URL) as test_client:
        yield test_client


@pytest.fixture
def worker(settings: Settings) -> Iterator[Worker]:
    """A real worker, driven in-process with ``run_once``."""
    w = local_worker(settings, worker_id="test-worker")
    yield w
    w.db.dispose()


@pytest.fixture
def single_worker(settings: Settings) -> Iterator[Worker]:
    """A real worker that claims one job at a time (``MGRAO_BATCH_JOBS=1``), driven with ``run_once``."""
    w = local_worker(settings.model_copy(update={"batch_jobs": 1}), worker_id="test-single-worker")
    yield w
    w.db.dispose()


@pytest.fixture
def db(settings: Settings) -> Iterator[Database]:
    database = Database(settings.database_url)
    database.migrate()
    yield database
    database.dispose()


@pytest.fixture
def service(tmp_path: Path, db_url: str) -> Iterator[Service]:
    svc = Service(tmp_path, db_url)
    yield svc
    svc.stop()


@pytest.fixture(scope="session")
def live_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """Base URL of one real `mgrao serve` (no workers, default settings) for tests of real HTTP traffic."""
    tmp = tmp_path_factory.mktemp("live")
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("MGRAO_")}
    with open(tmp / "serve.log", "wb") as log:
        process = subprocess.Popen(serve_command(port, 0, f"sqlite:///{tmp / 'live.db'}"), env=env,
                                   stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        wait_healthy(base, process)
    except RuntimeError as error:
        stop(process)
        pytest.fail(f"mgrao serve did not start: {error}\n{(tmp / 'serve.log').read_text(errors='replace')[-3000:]}")
    yield base
    stop(process, timeout=15)
