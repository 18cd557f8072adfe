"""The runs table as a researcher sorts it: a configuration's results and any parameter as columns,
sorted on the server by clicking their headers; and the table fits a 1280x800 screen."""

from __future__ import annotations

import time

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
    context = browser.new_context(viewport={"width": 1280, "height": 800}, base_url=server)
    page = context.new_page()
    page.set_default_timeout(20000)
    try:
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
    finally:
        context.close()


def test_runs_table_fits_1280_with_its_cancel_button_in_view(browser, server, screenshots):
    slow = post_job(server, {"system": "large", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 4, "episodes": 3000,
                             "params": {"n_parents": 1000}, "name": "a long job with a long name to wrap",
                             "tags": ["fit", "layout"]})
    context = browser.new_context(viewport={"width": 1280, "height": 800}, base_url=server)
    page = context.new_page()
    page.set_default_timeout(20000)
    try:
        page.goto("/#/runs")
        cancel = page.get_by_role("button", name=f"Cancel job {slow['id']}")
        cancel.wait_for()
        wrap = page.locator(".table-wrap").first
        overflow = wrap.evaluate("el => el.scrollWidth - el.clientWidth")
        assert overflow <= 1, f"the runs table scrolls sideways by {overflow} px at 1280x800"
        box = cancel.bounding_box()
        assert box is not None and box["x"] + box["width"] <= 1280
        page.screenshot(path=str(screenshots / "runs-1280.png"))
        cancel.click()
        page.get_by_role("dialog").get_by_role("button", name="Cancel job").click()
        page.locator(f'tr[data-id="{slow["id"]}"][data-status="cancelled"]').wait_for()
    finally:
        context.close()
