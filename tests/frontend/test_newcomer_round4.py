"""A newcomer's first hour, round 4 (issue 43): what the dashboard shows, seen in a real browser."""

from __future__ import annotations

from tests.frontend.conftest import page_at
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_job_view import post_job
from tests.frontend.test_newcomer_round2 import console_errors


def test_compare_says_a_job_whose_seeds_are_a_subset_of_anothers_was_read(browser, server, screenshots):
    """Issue 43, item 15: the subset job was read and checked but not listed beside its configuration."""
    whole = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 4,
                              "episodes": 12, "name": "round4 whole"})
    part = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-1:1"], "seeds": [1, 2],
                             "episodes": 12, "name": "round4 part"})
    wait_succeeded(server, [whole, part])
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto(f"/#/compare?jobs={whole['id']},{part['id']}")
        cell = page.locator("td.job-links").first
        cell.wait_for()
        assert cell.locator("a").all_inner_texts() == [f"#{whole['id']}", f"#{part['id']}"]
        checked = cell.locator("span.checked-job")
        assert checked.inner_text() == f"#{part['id']} (checked)"
        assert "none is counted twice" in checked.get_attribute("title")
        page.screenshot(path=str(screenshots / "compare-subset-job-checked.png"), full_page=True)
        assert errors == [], errors
