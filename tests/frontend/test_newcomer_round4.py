"""A newcomer's first hour, round 4 (issue 43): what the dashboard shows, seen in a real browser."""

from __future__ import annotations

from tests.frontend.conftest import page_at, running_service
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_dashboard import api
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


# seeds of the single system whose mgrao-1:1 interval ends at +23.38%, just below the paper's +23.4%: at one decimal
# both read +23.4% (issue 43, item 12)
CLOSE_CALL_SEEDS = [31, 75, 99, 114, 130, 171, 174]


def test_an_interval_and_the_papers_figure_read_alike_on_the_job_page_and_the_paper_view(browser, tmp_path,
                                                                                          screenshots):
    """Issue 43, item 12: the paper view wrote [+23.28%, +27.99%] "outside" +28.00%, the job page [+23.3%, +28.0%]."""
    from mgrao_core.statistics.report import deciding_digits

    with running_service(tmp_path, workers=1) as base:  # its own: the paper view takes the paper job with most seeds
        job = post_job(base, {"system": "single", "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"],
                              "seeds": CLOSE_CALL_SEEDS, "episodes": 100, "name": "a close call"})
        wait_succeeded(base, [job])
        results = api(base, "GET", f"/jobs/{job['id']}/results?points=10")
        summary = {c["algorithm"]: c["summary"] for c in results["configurations"]}
        low, high = summary["mgrao-1:1"]["pct_ci95"]
        paper = results["paper"]["mgrao-1:1"]
        digits = deciding_digits((low, high), paper)
        assert high < paper and digits == 2, (low, high, paper)  # outside, by less than the first decimal shows
        said = (f"[{low:+.{digits}f}%, {high:+.{digits}f}%]", f"{paper:+.{digits}f}%")
        with page_at(browser, base) as page:
            errors = console_errors(page)
            page.goto(f"/#/jobs/{job['id']}")
            row = page.locator("table.summary tbody tr", has=page.locator("th", has_text="mgrao-1:1"))
            row.locator("td.paper").wait_for()
            cells = row.locator("td").all_inner_texts()  # runs, final mean, its CI, % from uniform, its CI, ...
            on_job_page = (cells[4], row.locator("td.paper").inner_text())
            assert on_job_page == said, on_job_page
            page.screenshot(path=str(screenshots / "job-interval-against-the-paper.png"), full_page=True)
            page.goto("/#/paper")
            row = page.locator('#paper-table tr[data-system="single"][data-algorithm="mgrao-1:1"]')
            row.wait_for()
            cells = row.locator("td").all_inner_texts()
            assert (cells[4], cells[5]) == said and "outside" in cells[6], cells
            assert errors == [], errors
