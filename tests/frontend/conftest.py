"""Fixtures for the dashboard's browser tests: a real `mgrao serve` and headless Debian Chromium."""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from tests.support.local_service import free_port, serve_command, stop, wait_healthy

# expect()'s own default is 5 s, which a busy machine's render can take; a wait ends as soon as it holds
EXPECT_TIMEOUT_MS = 30_000

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = os.environ.get("MGRAO_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]
SCREENSHOTS = ROOT / "test-output" / "screenshots"


@contextmanager
def running_service(tmp: Path, workers: int, **env: str) -> Iterator[str]:
    """A real `mgrao serve` on 127.0.0.1 with its own SQLite file in ``tmp`` and ``env`` set; its base URL.

    The caller's MGRAO_API_TOKEN is not passed on (one in ``env`` is). Stopped (by process id) on
    leaving; a service that does not come up fails the test with its log.
    """
    port = free_port()
    environment = {**os.environ, "MGRAO_DATABASE_URL": f"sqlite:///{tmp / 't.db'}"}
    environment.pop("MGRAO_API_TOKEN", None)
    environment |= env
    with open(tmp / "serve.log", "wb") as log:
        proc = subprocess.Popen(serve_command(port, workers=workers), env=environment, cwd=ROOT, stdout=log,
                                stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    try:
        try:
            wait_healthy(base, proc)
        except RuntimeError as e:
            pytest.fail(f"could not start mgrao serve: {e}\n{(tmp / 'serve.log').read_text(errors='replace')[-3000:]}")
        yield base
    finally:
        stop(proc, timeout=15)


@contextmanager
def page_at(browser, base: str, width: int = 1280, height: int = 800) -> Iterator:
    """A page of a fresh browser context on ``base`` (a minute's default timeout), closed on leaving."""
    context = browser.new_context(viewport={"width": width, "height": height}, base_url=base, accept_downloads=True)
    page = context.new_page()
    page.set_default_timeout(60000)
    try:
        yield page
    finally:
        close_context(context)


def close_context(context) -> None:
    """Close a browser context once none of its route handlers runs (``unroute_all`` waits for those that do).

    A handler that calls ``route.fetch()`` could still be running, or be due, when its test ended: closed under it,
    its fetch failed with "Request context disposed", and Playwright's sync API raised that into whichever test of
    the same worker next called it (seen once in a whole run in a random order, in the test after
    test_memory_per_child_is_shown_when_the_registry_gives_it). A request due after the routes are gone goes on
    unrouted to a context that is closing.
    """
    for page in context.pages:
        page.unroute_all(behavior="wait")
    context.unroute_all(behavior="wait")
    context.close()


SETTLE_READS = 3
"""Consecutive equal reads (100 ms apart) that make a layout settled."""


def settled_boxes(page, selectors: list[str], what: str, timeout: float = 30.0) -> dict[str, dict]:
    """Each selector's box (the first match; page coordinates) once the layout has kept still.

    plotly lays a chart out in passes (its margins grow to fit the legend and titles, a responsive chart follows
    its element's size), and a drawn chart's mark can come before the last of them: a read of the boxes then
    races the layout. This reads them every 100 ms until SETTLE_READS reads in a row agree, within ``timeout``
    seconds (else the test fails, saying what it waited for and the last boxes).
    """
    deadline = time.monotonic() + timeout
    previous, still = None, 0
    while True:
        boxes = page.evaluate("""(selectors) => Object.fromEntries(selectors.map((s) => {
            const el = document.querySelector(s);
            if (!el) return [s, null];
            const r = el.getBoundingClientRect();
            return [s, {x: r.x + window.scrollX, y: r.y + window.scrollY, width: r.width, height: r.height}]; }))""",
                              selectors)
        still = still + 1 if all(boxes.values()) and boxes == previous else 0
        if still >= SETTLE_READS - 1:
            return boxes
        assert time.monotonic() < deadline, f"{what}: the layout did not settle within {timeout} s; last {boxes}"
        previous = boxes
        time.sleep(0.1)


@pytest.fixture(scope="session")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """Base URL of a running service. MGRAO_DASHBOARD_URL points the tests at an existing one instead."""
    external = os.environ.get("MGRAO_DASHBOARD_URL")
    if external:
        wait_healthy(external.rstrip("/"), None, timeout=10)
        yield external.rstrip("/")
        return
    with running_service(tmp_path_factory.mktemp("dashboard"), workers=2) as base:
        yield base


@pytest.fixture(scope="session")
def browser():
    if not Path(CHROMIUM).exists():
        pytest.skip(f"{CHROMIUM} is absent: install Debian's chromium (apt-get install chromium) for browser tests")
    from playwright.sync_api import expect, sync_playwright

    expect.set_options(timeout=EXPECT_TIMEOUT_MS)
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture
def page(browser, server):
    """A fresh page at 1366x768 that records every request URL in `page.requests`."""
    context = browser.new_context(viewport={"width": 1366, "height": 768}, accept_downloads=True, base_url=server)
    pg = context.new_page()
    pg.requests = []  # type: ignore[attr-defined]
    pg.on("request", lambda r: pg.requests.append(r.url))
    pg.set_default_timeout(20000)
    yield pg
    close_context(context)


@pytest.fixture(scope="session")
def screenshots() -> Path:
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)
    return SCREENSHOTS
