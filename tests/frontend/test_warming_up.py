"""A job submitted while the workers compile the kernel says so, and the header counts warming workers.

Real `mgrao serve` with one real worker whose numba cache directory is empty (NUMBA_CACHE_DIR), so
that it compiles the kernel as on a fresh install; a real SQLite file; headless Chromium.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.frontend.conftest import page_at, running_service
from tests.frontend.test_form_messages import health
from tests.frontend.test_job_view import post_job, wait_for


@pytest.fixture
def cold_server(tmp_path: Path) -> Iterator[str]:
    with running_service(tmp_path, workers=1, NUMBA_CACHE_DIR=str(tmp_path / "numba-cache"),
                         MGRAO_HEARTBEAT_S="0.5", MGRAO_STALE_AFTER_S="4") as base:
        yield base


def test_a_job_waiting_for_warming_workers_says_so(browser, cold_server, screenshots):
    job = post_job(cold_server, {"system": "single", "seeds": 2, "episodes": 20, "name": "first job"})
    # the header reads the workers when the page loads (then every 10 s): load it once the worker has said so
    wait_for(lambda: (health(cold_server)["workers"] or {}).get("warming") == 1, 60, "the worker to report warming")
    with page_at(browser, cold_server) as page:
        page.goto(f"/#/jobs/{job['id']}")
        waiting = page.locator("#job-waiting")
        waiting.wait_for()
        page.wait_for_function("() => /warming up/.test(document.getElementById('job-waiting').textContent)",
                               timeout=30000)
        assert "loading the simulation kernel" in waiting.inner_text()
        page.wait_for_function("() => /1 worker warming up/.test(document.getElementById('health').textContent)",
                               timeout=30000)
        page.screenshot(path=str(screenshots / "job-warming-up.png"))
        # compiled: the worker reports ready, runs the job, and the header counts it as a worker
        page.locator("#utility-chart .main-svg").first.wait_for(timeout=180000)
        page.evaluate("window.dispatchEvent(new CustomEvent('jobs-changed'))")
        page.wait_for_function("() => /· 1 worker$/.test(document.getElementById('health').textContent)",
                               timeout=15000)
