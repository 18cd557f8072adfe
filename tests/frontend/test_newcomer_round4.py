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


def test_the_runs_table_fits_1024_px_and_sorts_unnamed_jobs_last(browser, server, screenshots):
    """Issue 43, item 14: at 1024 px Duration and Actions were cut off; "Name A-Z" put the unnamed "job 1" first."""
    every = ["uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-25:1", "mgrao-max"]
    jobs = [post_job(server, {"system": "large", "algorithms": every, "seeds": 1, "episodes": 5,
                              "name": "every configuration of large", "tags": ["round4-runs", "paper-figure"]}),
            post_job(server, {"system": "single", "algorithms": ["uniform"], "seeds": 1, "episodes": 5,
                              "name": "a named one", "tags": ["round4-runs"]}),
            post_job(server, {"system": "single", "algorithms": ["uniform"], "seeds": 1, "episodes": 5,
                              "tags": ["round4-runs"]})]  # the newest: first until sorted by name
    wait_succeeded(server, jobs)
    with page_at(browser, server, width=1024, height=768) as page:
        errors = console_errors(page)
        page.goto("/#/runs?tag=round4-runs")
        page.locator("table.runs tbody tr").nth(2).wait_for()
        wrap = page.locator(".table-wrap").first
        scroll, client = wrap.evaluate("el => [el.scrollWidth, el.clientWidth]")
        assert scroll <= client, (scroll, client)  # nothing to scroll to: every column on screen
        right = wrap.bounding_box()["x"] + wrap.bounding_box()["width"]
        for header in ("Duration", "Actions"):
            box = page.locator("table.runs thead th", has_text=header).bounding_box()
            assert box["x"] + box["width"] <= right + 0.5, (header, box, right)
        delete = page.locator(f"table.runs tbody tr[data-id='{jobs[0]['id']}'] button", has_text="Delete")
        box = delete.bounding_box()
        assert box["x"] + box["width"] <= right + 0.5, (box, right)
        page.screenshot(path=str(screenshots / "runs-at-1024.png"), full_page=True)
        page.locator("select[name=sort]").select_option("name")
        page.wait_for_function("(id) => document.querySelector('table.runs tbody tr:last-child')?.dataset.id === id",
                               arg=str(jobs[2]["id"]), timeout=30000)
        names = page.locator("table.runs tbody td.job-name a").all_inner_texts()
        assert names == ["a named one", "every configuration of large", f"job {jobs[2]['id']}"], names
        assert errors == [], errors
