"""The runs table as a researcher sorts it: a configuration's results and any parameter as columns,
sorted on the server by clicking their headers; and the table fits a 1280x800 screen."""

from __future__ import annotations

import time
import urllib.error

from tests.frontend.conftest import page_at
from tests.frontend.test_dashboard import api
from tests.frontend.test_job_view import get_job, post_job

RATES = [0.5, 0.05, 0.2]


def cells(page, column: str) -> list[str]:
    return page.locator(f'td[data-column="{column}"]').all_inner_texts()


def test_result_and_parameter_columns_sort_by_header(browser, server, screenshots):
    jobs = [post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3, "episodes": 40,
                              "params": {"learning_rate": rate}, "name": f"lr {rate}", "tags": ["columns"]})
            for rate in RATES]
    deadline = time.monotonic() + 120
    while any(get_job(server, j["id"])["status"] != "succeeded" for j in jobs):
        assert time.monotonic() < deadline, "jobs did not finish"
        time.sleep(0.3)
    with page_at(browser, server) as page:
        page.goto("/#/runs?tag=columns&result=mgrao-max&cols=learning_rate")
        page.locator("tbody tr").nth(len(RATES) - 1).wait_for()
        header = page.locator('button.sort-header[data-sort="pct_from_uniform:mgrao-max"]')
        header.click()  # a result sorts highest first
        page.locator('th[aria-sort="descending"] button[data-sort="pct_from_uniform:mgrao-max"]').wait_for()
        page.wait_for_function("() => !document.querySelector('[aria-busy=true]')")
        gains = [float(t.rstrip("%")) for t in cells(page, "pct_from_uniform:mgrao-max")]
        assert len(gains) == len(RATES) and gains == sorted(gains, reverse=True)
        assert "95% CI" in page.locator('td[data-column="final_mean:mgrao-max"]').first.get_attribute("title")
        header.click()  # again: lowest first
        page.locator('th[aria-sort="ascending"] button[data-sort="pct_from_uniform:mgrao-max"]').wait_for()
        page.wait_for_function("() => !document.querySelector('[aria-busy=true]')")
        assert [float(t.rstrip("%")) for t in cells(page, "pct_from_uniform:mgrao-max")] == sorted(gains)
        page.locator('button.sort-header[data-sort="param.learning_rate"]').click()
        page.locator('th[aria-sort="ascending"] button[data-sort="param.learning_rate"]').wait_for()
        page.wait_for_function("() => !document.querySelector('[aria-busy=true]')")
        assert [float(t) for t in cells(page, "param.learning_rate")] == sorted(RATES)
        assert "sort=param.learning_rate" in page.url and "cols=learning_rate" in page.url
        page.screenshot(path=str(screenshots / "runs-columns.png"), full_page=True)
        page.reload()  # the URL keeps the columns and the order
        page.locator('th[aria-sort="ascending"] button[data-sort="param.learning_rate"]').wait_for()
        page.locator("tbody tr").nth(len(RATES) - 1).wait_for()
        assert [float(t) for t in cells(page, "param.learning_rate")] == sorted(RATES)


def cancel(base: str, job_id: int) -> None:
    """Cancel a job that may already have ended (409 then)."""
    try:
        api(base, "POST", f"/jobs/{job_id}/cancel")
    except urllib.error.HTTPError as e:
        if e.code != 409:
            raise


def test_runs_table_fits_1280_with_its_cancel_button_in_view(browser, server, screenshots):
    """The widest rows the table can hold: a name with no place to break, notes, a 50-character tag, every
    configuration, and jobs both running and queued (three slow jobs for the session's two workers), whatever
    earlier tests left on the page."""
    wide = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max"],
                             "seeds": 2, "episodes": 20, "name": "reproduction_of_table_two_with_a_long_name_" * 2,
                             "notes": "a note that goes on about the learning rate and the seeds chosen " * 3,
                             "tags": ["t" * 50, "layout"]})
    slow = [post_job(server, {"system": "large", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 30, "episodes": 3000,
                              "params": {"n_parents": 1000}, "name": f"a long job with a long name to wrap {i}",
                              "tags": ["fit", "layout"]}) for i in range(3)]
    try:
        with page_at(browser, server) as page:
            page.goto("/#/runs")
            page.locator(f'tr[data-id="{wide["id"]}"]').wait_for()
            for job in slow:
                page.get_by_role("button", name=f"Cancel job {job['id']}").wait_for()
            page.locator('tr[data-status="running"]').first.wait_for()
            for _ in range(10):  # while the rows' states settle, the table must fit at every step
                wrap = page.locator(".table-wrap").first
                overflow = wrap.evaluate("el => el.scrollWidth - el.clientWidth")
                assert overflow <= 1, f"the runs table scrolls sideways by {overflow} px at 1280x800"
                page.wait_for_timeout(200)
            statuses = page.locator("tbody tr").evaluate_all("rows => rows.map((r) => r.dataset.status)")
            assert "running" in statuses
            cancel_button = page.get_by_role("button", name=f"Cancel job {slow[0]['id']}")
            box = cancel_button.bounding_box()
            assert box is not None and box["x"] + box["width"] <= 1280
            assert page.get_by_role("button", name=f"Filter by tag {'t' * 50}").get_attribute("title") == "t" * 50
            page.screenshot(path=str(screenshots / "runs-1280.png"))
            cancel_button.click()
            page.get_by_role("dialog").get_by_role("button", name="Cancel job").click()
            page.locator(f'tr[data-id="{slow[0]["id"]}"][data-status="cancelled"]').wait_for()
    finally:
        for job in slow:  # the one cancelled through the page answers 409
            cancel(server, job["id"])


def test_a_progress_answer_older_than_a_cancel_does_not_bring_the_row_back(browser, server):
    """The runs page reads its rows again when a job changes; a listing on its way while the row is
    cancelled says "running" and must not replace the newer, cancelled row. The answer is held back
    here (the route) until the cancel has been shown, then delivered."""
    job = post_job(server, {"system": "large", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 30, "episodes": 3000,
                            "params": {"n_parents": 1000}, "name": "stale poll", "tags": ["stale-poll"]})
    held = []

    def hold_first_listing(route) -> None:
        if held:
            route.continue_()
        else:
            held.append((route, route.fetch()))  # the job's state now: queued or running

    try:
        with page_at(browser, server) as page:
            page.goto("/#/runs?tag=stale-poll")
            row = page.locator(f'tr[data-id="{job["id"]}"]')
            row.wait_for()
            page.route("**/api/jobs?*", hold_first_listing)
            # a change elsewhere moves the poll's token: the page reads its rows again
            post_job(server, {"system": "single", "seeds": 1, "episodes": 5, "name": "a change"})
            deadline = time.monotonic() + 30
            while not held:  # the listing the change asks for is caught
                assert time.monotonic() < deadline, "the runs page did not read its rows again after a change"
                page.wait_for_timeout(100)
            route, answer = held[0]
            assert [j["status"] for j in answer.json()["data"] if j["id"] == job["id"]][0] in ("queued", "running")
            page.get_by_role("button", name=f"Cancel job {job['id']}").click()
            page.get_by_role("dialog").get_by_role("button", name="Cancel job").click()
            page.locator(f'tr[data-id="{job["id"]}"][data-status="cancelled"]').wait_for()
            route.fulfill(response=answer)  # the stale answer arrives after the cancel
            page.wait_for_timeout(1500)
            assert row.get_attribute("data-status") == "cancelled"
            page.unroute("**/api/jobs?*")
    finally:
        cancel(server, job["id"])
