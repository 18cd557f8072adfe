"""Fixtures: a real database per test (a SQLite file, and a database on a real PostgreSQL server that
the session starts and stops), the app in-process, and real server/worker processes.

Every test that takes ``db_url`` (directly or through ``settings``, ``client``, ``worker``, ``db`` or
``service``) runs twice, ``[sqlite]`` and ``[postgresql]``; the PostgreSQL runs skip, saying why,
only where no PostgreSQL server can be started (see tests/support/postgres.py).

``db_url`` is a new database of its own, migrated to the newest revision and empty: a copy of a template
migrated once per test run (a copy of a SQLite file, which all pytest-xdist workers share; PostgreSQL's
``CREATE DATABASE ... TEMPLATE``, once per worker's server), instead of migrating each (0.1 s on SQLite,
0.6-2.5 s on PostgreSQL). Two markers change that:

* ``empty_database``: ``db_url`` has no schema at all (the migrations' own tests: they migrate it themselves);
* ``one_database``: only ``[sqlite]``, for a test whose check cannot reach the database (a request refused
  before any route reads it, a static file): the store, the queue, migrations, studies and everything that
  reads or writes rows keep running on both.
"""

from __future__ import annotations

import os
import shutil
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
from tests.support.shared import made_once, run_directory

DATABASES = ("sqlite", "postgresql")


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """``db_url``'s kinds: both, or SQLite alone for a test marked ``one_database`` (see the module)."""
    if "db_url" in metafunc.fixturenames:
        one = metafunc.definition.get_closest_marker("one_database") is not None
        metafunc.parametrize("db_url", DATABASES[:1] if one else DATABASES, indirect=True)


def _migrate(url: str) -> None:
    database = Database(url)
    try:
        database.migrate()
    finally:
        database.dispose()  # nobody may be connected to a template that is copied


@pytest.fixture(scope="session")
def sqlite_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A SQLite file migrated once per test run, in the directory every xdist worker shares."""
    return made_once(run_directory(tmp_path_factory), "template.sqlite", lambda path: _migrate(f"sqlite:///{path}"),
                     "migrating the template SQLite database")


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    with throwaway_server() as server:
        yield server


@pytest.fixture(scope="session")
def postgres_template(postgres_server: PostgresServer) -> str:
    """The URL of a database migrated once on this worker's server, copied by ``CREATE DATABASE ... TEMPLATE``."""
    url = postgres_server.create_database()
    _migrate(url)
    return url


@pytest.fixture
def db_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    empty = request.node.get_closest_marker("empty_database") is not None
    if request.param == "sqlite":
        path = tmp_path / "mgrao.db"
        if not empty:
            shutil.copyfile(request.getfixturevalue("sqlite_template"), path)
        yield f"sqlite:///{path}"
        return
    server: PostgresServer = request.getfixturevalue("postgres_server")
    url = server.create_database(template=None if empty else request.getfixturevalue("postgres_template"))
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
