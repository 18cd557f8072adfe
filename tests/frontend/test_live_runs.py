"""The runs table and the header follow jobs submitted elsewhere (issue "the dashboard as a newcomer
reads it, round 2", 2): a job posted through the API appears under the table's filters and sort,
its state moves, and the header's counts follow; one light request per poll, none once the view is
left or the tab is hidden."""

from __future__ import annotations

import re
import time
import uuid

import pytest

from tests.frontend.conftest import page_at
from tests.frontend.test_dashboard import api
from tests.frontend.test_job_view import post_job, wait_for

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def requests_to(page, pattern: str) -> int:
    return sum(1 for u in page.requests if re.search(pattern, u))


def header_matches_health(page, base: str) -> bool:
    reading = api(base, "GET", "/health")
    return f"{reading['running']} running · {reading['queued']} queued" in page.inner_text("#health")


def test_jobs_submitted_elsewhere_appear_and_move_under_the_filters(browser, server, screenshots):
    tag = f"live-{uuid.uuid4().hex[:8]}"
    with page_at(browser, server) as page:
        page.requests = []
        page.on("request", lambda r: page.requests.append(r.url))
        page.goto(f"/#/runs?tag={tag}&sort=name")
        page.locator(".notice.empty").wait_for()  # none yet with this tag
        other = post_job(server, {"system": "single", "seeds": 1, "episodes": 5, "name": "a other",
                                  "tags": ["elsewhere"]})
        second = post_job(server, {"system": "single", "seeds": 2, "episodes": 30, "name": "b live", "tags": [tag]})
        first = post_job(server, {"system": "single", "seeds": 2, "episodes": 30, "name": "a live", "tags": [tag]})
        submitted = time.monotonic()
        page.locator(f'tr[data-id="{first["id"]}"]').wait_for(timeout=20000)  # generous: ~1 s expected
        page.locator(f'tr[data-id="{second["id"]}"]').wait_for(timeout=20000)
        appeared = time.monotonic() - submitted
        ids = page.locator("table.runs tbody tr").evaluate_all("rows => rows.map(r => Number(r.dataset.id))")
        assert ids == [first["id"], second["id"]], f"sorted by name under tag {tag}: {ids}"
        assert page.locator(f'tr[data-id="{other["id"]}"]').count() == 0, "a job of another tag was shown"
        assert "2 jobs" in page.inner_text("p.count")
        for job in (first, second):
            page.locator(f'tr[data-id="{job["id"]}"][data-status="succeeded"]').wait_for(timeout=120000)
        wait_for(lambda: header_matches_health(page, server), 20, "the header's counts to match /api/health")
        page.screenshot(path=str(screenshots / "runs-live.png"))
        print(f"submitted through the API -> row shown in {appeared:.2f} s")
        # One light poll, no request per row: the rows were read again by whole listings only.
        # (page.evaluate lets Playwright deliver the request events that arrived while the test slept)
        wait_for(lambda: page.evaluate("1") and requests_to(page, r"/api/jobs/changes\?") >= 2, 20,
                 "the light poll to ask again with its token")
        assert requests_to(page, r"/api/jobs/\d+(\?|$)") == 0, "rows were polled one by one"

        # Leaving the view stops its listings; a hidden tab stops the poll itself.
        page.goto("/#/compare")
        page.locator("h1").wait_for()
        lists = requests_to(page, r"/api/jobs\?")
        post_job(server, {"system": "single", "seeds": 1, "episodes": 5, "name": "while away", "tags": [tag]})
        page.wait_for_timeout(3000)
        assert requests_to(page, r"/api/jobs\?") == lists, "the runs table still reloaded after the view was left"
        page.evaluate("""() => { Object.defineProperty(document, 'hidden', { value: true, configurable: true });
                                  document.dispatchEvent(new Event('visibilitychange')); }""")
        page.wait_for_timeout(1500)  # an answer on its way when the tab was hidden
        polls = requests_to(page, r"/api/jobs/changes")
        page.wait_for_timeout(3000)
        assert requests_to(page, r"/api/jobs/changes") == polls, "the poll went on in a hidden tab"
        page.evaluate("""() => { Object.defineProperty(document, 'hidden', { value: false, configurable: true });
                                  document.dispatchEvent(new Event('visibilitychange')); }""")
        wait_for(lambda: page.evaluate("1") and requests_to(page, r"/api/jobs/changes") > polls, 10,
                 "the poll to resume on a visible tab")
