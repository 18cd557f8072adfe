"""The "ours against the paper" view: the paper's tables beside our newest paper runs, each figure
flagged where the published value lies outside our 95% interval, with the reproduction notes linked."""

from __future__ import annotations

import json
import urllib.request

from tests.frontend.conftest import page_at
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_job_view import post_job


def test_ours_against_the_paper(browser, server, screenshots):
    with urllib.request.urlopen(f"{server}/api/systems", timeout=30) as answer:
        systems = json.loads(answer.read())["systems"]
    jobs = [post_job(server, {"system": s["name"], "algorithms": s["algorithms"], "seeds": 8, "episodes": 100,
                              "tags": ["paper"], "name": f"paper {s['name']}"}) for s in systems]
    wait_succeeded(server, jobs)
    with page_at(browser, server) as page:
        errors = []
        page.on("pageerror", lambda error: errors.append(error))
        page.goto("/#/paper")
        page.locator("#paper-table").wait_for()
        rows = page.locator("#paper-table tbody tr")
        expected = sum(len(s["paper"]) for s in systems)
        assert rows.count() == expected
        flags = page.locator("#paper-table td.flag").all_inner_texts()
        assert set(flags) <= {"within", "⚑ outside"} and len(flags) == expected  # every figure judged
        outside = page.locator("#paper-table tr.outside").count()
        assert f"{expected - outside} of {expected} figures" in page.inner_text("#paper-agreement")
        first = rows.first
        assert first.get_attribute("data-system") == systems[0]["name"]
        assert first.locator("a").get_attribute("href").startswith("#/jobs/")
        doc = page.get_attribute("#reproduction-doc", "href")
        with urllib.request.urlopen(f"{server}{doc}", timeout=30) as answer:
            assert answer.status == 200 and b"reproduc" in answer.read().lower()
        page.screenshot(path=str(screenshots / "paper.png"), full_page=True)
        assert not errors
