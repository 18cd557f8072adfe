"""Browser tests of the dashboard against a real `mgrao serve` (headless Debian Chromium)."""

from __future__ import annotations

import json
import re
import time
import urllib.error
import urllib.request
from urllib.parse import urlparse

import pytest
from playwright.sync_api import expect

from tests.frontend.conftest import page_at

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def api(base: str, method: str, path: str, body: dict | None = None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(
        f"{base}/api{path}", data=data, method=method, headers={"Content-Type": "application/json"}
    )
    with urllib.request.urlopen(req, timeout=30) as r:
        text = r.read()
        return json.loads(text) if text else None


def wait_job(base: str, job_id: int, timeout: float = 120.0) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        job = api(base, "GET", f"/jobs/{job_id}")
        if job["status"] in ("succeeded", "failed", "cancelled"):
            return job
        time.sleep(0.3)
    raise AssertionError(f"job {job_id} did not finish in {timeout} s")


def assert_local(page, base: str) -> None:
    host = urlparse(base).netloc
    outside = [u for u in page.requests if not (u.startswith(("data:", "blob:")) or urlparse(u).netloc == host)]
    assert not outside, f"requests left {host}: {outside}"
    assert all(urlparse(u).hostname == "127.0.0.1" for u in page.requests if u.startswith("http"))


def traces(page, selector: str) -> list[dict]:
    return page.evaluate(
        """sel => (document.querySelector(sel).data || []).map(t => ({
            kind: t.meta && t.meta.kind, config: t.meta && t.meta.config,
            n: (t.x || []).length, fill: t.fill || null}))""",
        selector,
    )


def wait_rendered(page, selector: str, after: str | None = None) -> str:
    """Wait until the chart's data-rendered stamp exists (and differs from `after`)."""
    page.wait_for_function(
        """([sel, prev]) => { const el = document.querySelector(sel);
            return el && el.dataset.rendered && el.dataset.rendered !== prev; }""",
        arg=[selector, after or ""],
    )
    return page.eval_on_selector(selector, "el => el.dataset.rendered")


def test_submit_job_progress_chart_table_csv(page, server, screenshots):
    page.goto("/#/new")
    page.get_by_label("System preset").select_option("single")
    page.get_by_label("Seeds (number of runs)").fill("3")
    page.get_by_label("Episodes per run").fill("100")
    page.get_by_label("Name", exact=True).fill("browser test job")
    page.get_by_label("Tags").fill("browser, e2e")
    page.screenshot(path=str(screenshots / "new-experiment.png"), full_page=True)
    page.get_by_role("button", name="Run experiment").click()

    page.wait_for_url(re.compile(r"#/jobs/\d+"))
    job_id = int(re.search(r"#/jobs/(\d+)", page.url).group(1))
    # Live progress while the job is queued or running. A warm worker can finish this small job (0.1-0.5 s)
    # before the view's first answer; then it opens on the results (tests/frontend/test_job_view.py covers
    # progress on a long job).
    page.locator("#job-progress, #utility-chart[data-rendered]").first.wait_for(timeout=30000)
    if page.locator("#job-progress").is_visible():
        page.screenshot(path=str(screenshots / "job-running.png"), full_page=True)

    # No reload: polling turns the page into results once the job succeeds.
    wait_rendered(page, "#utility-chart")
    job = wait_job(server, job_id)  # the chart can draw stored runs a moment before the job is marked done
    assert job["status"] == "succeeded"
    algorithms = job["algorithms"]
    data = traces(page, "#utility-chart")
    means = [t for t in data if t["kind"] == "mean"]
    bands = [t for t in data if t["kind"] == "band"]
    assert sorted(t["config"] for t in means) == sorted(algorithms)
    assert sorted(t["config"] for t in bands) == sorted(algorithms)
    assert all(t["n"] == 100 for t in means) and all(t["n"] == 200 and t["fill"] == "toself" for t in bands)

    # Smoothing keeps one line and one band per configuration; seeds on demand add 3 per configuration.
    stamp = page.eval_on_selector("#utility-chart", "el => el.dataset.rendered")
    page.get_by_label("Smoothing (centred mean)").select_option("5")
    stamp = wait_rendered(page, "#utility-chart", stamp)
    assert len([t for t in traces(page, "#utility-chart") if t["kind"] == "mean"]) == len(algorithms)
    assert "smooth=5" in page.url
    page.get_by_label("Show individual seeds").check()
    wait_rendered(page, "#utility-chart", stamp)
    seeds = [t for t in traces(page, "#utility-chart") if t["kind"] == "seed"]
    assert len(seeds) == 3 * len(algorithms)

    # Paper-style table with the published figure (the job uses the preset's own parameters).
    table = page.locator("table.summary")
    assert table.locator("tbody tr").count() == len(algorithms)
    assert "Paper: % from uniform" in table.locator("thead").inner_text()
    assert "+28.0%" in table.inner_text()  # single, mgrao-max in the paper

    # Weights: heatmap for a learning configuration and the combined-weights bars.
    page.locator("#weights-bars .main-svg").first.wait_for()
    assert page.eval_on_selector("#weights-heatmap", "el => (el.data || [])[0].type") == "heatmap"
    page.screenshot(path=str(screenshots / "job-results.png"), full_page=True)
    page.emulate_media(media="print")
    assert page.locator("nav[aria-label=Main]").is_hidden()  # the print stylesheet drops the controls
    page.screenshot(path=str(screenshots / "job-results-print.png"), full_page=True)
    page.emulate_media(media="screen")

    # CSV download: algorithms x seeds x episodes rows plus the header.
    with page.expect_download() as info:
        page.get_by_role("link", name="Episodes as CSV").click()
    path = info.value.path()
    lines = [ln for ln in open(path, encoding="utf-8").read().splitlines() if ln.strip()]
    assert lines[0] == "job_id,algorithm,seed,episode,utility"
    assert len(lines) == len(algorithms) * 3 * 100 + 1
    assert_local(page, server)


def test_bad_parameter_message_beside_its_field(page, server, screenshots):
    page.goto("/#/new")
    page.get_by_label("System preset").select_option("single")
    page.locator("details.advanced > summary").click()
    n_parents = page.locator('[data-field="params.n_parents"]')
    n_parents.fill("2000000")
    page.get_by_role("button", name="Run experiment").click()
    field = page.locator('.field[data-for="params.n_parents"]')
    error = field.locator(".field-error")
    error.wait_for(state="visible")
    assert "must be in [1, 1000000]" in error.inner_text()
    assert "2000000" in error.inner_text()
    assert n_parents.get_attribute("aria-invalid") == "true"
    assert "#/new" in page.url  # nothing was created
    field.scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "new-experiment-error.png"))

    # Another field: seeds out of range is reported beside the seeds input.
    page.get_by_label("Seeds (number of runs)").fill("0")
    n_parents.fill("10")
    page.get_by_role("button", name="Run experiment").click()
    seeds_error = page.locator('.field[data-for="seeds"] .field-error')
    seeds_error.wait_for(state="visible")
    assert seeds_error.inner_text().strip()
    assert page.locator('.field[data-for="params.n_parents"] .field-error').is_hidden()
    assert_local(page, server)


@pytest.fixture(scope="module")
def two_jobs(server):
    common = {"system": "single", "episodes": 20, "tags": ["cmp"]}
    a = api(server, "POST", "/jobs", {**common, "seeds": [0, 1], "name": "cmp A"})
    b = api(server, "POST", "/jobs", {**common, "seeds": [2, 3], "name": "cmp B"})
    for j in (a, b):
        assert wait_job(server, j["id"])["status"] == "succeeded"
    return a["id"], b["id"]


def test_compare_two_jobs_and_reload(page, server, screenshots, two_jobs):
    a, b = two_jobs
    page.goto("/#/runs?tag=cmp")
    page.get_by_label(f"Select job {a} for comparison").check()
    page.get_by_label(f"Select job {b} for comparison").check()
    page.get_by_role("button", name="Compare selected (2)").click()
    page.wait_for_url(re.compile(r"#/compare\?jobs="))
    assert f"jobs={min(a, b)},{max(a, b)}" in page.url
    stamp = wait_rendered(page, "#compare-chart")
    data = traces(page, "#compare-chart")
    # Same configuration in both jobs pools into one group per algorithm: 3 lines + 3 bands.
    assert len([t for t in data if t["kind"] == "mean"]) == 3
    assert len([t for t in data if t["kind"] == "band"]) == 3
    page.locator("#compare-bars[data-rendered]").wait_for()  # below the fold: drawn once the page is idle
    bars = page.eval_on_selector("#compare-bars", "el => el.data[0]")
    assert bars["type"] == "bar" and "arrayminus" in bars["error_y"]
    page.screenshot(path=str(screenshots / "compare.png"), full_page=True)

    # Change the view: smoothing 5 and hide one group; the URL carries both.
    page.get_by_label("Smoothing (centred mean)").select_option("5")
    stamp = wait_rendered(page, "#compare-chart", stamp)
    page.get_by_label("single · uniform").uncheck()
    wait_rendered(page, "#compare-chart", stamp)
    assert len([t for t in traces(page, "#compare-chart") if t["kind"] == "mean"]) == 2
    url = page.url
    assert "smooth=5" in url and "groups=" in url

    # A copied link reproduces the view in a fresh page.
    other = page.context.new_page()
    other.goto(url)
    wait_rendered(other, "#compare-chart")
    assert other.get_by_label("Smoothing (centred mean)").input_value() == "5"
    assert not other.get_by_label("single · uniform").is_checked()
    kept = [t["config"] for t in traces(other, "#compare-chart") if t["kind"] == "mean"]
    assert kept == ["single · mgrao-1:1", "single · mgrao-max"]
    other.close()
    page.reload()
    wait_rendered(page, "#compare-chart")
    assert len([t for t in traces(page, "#compare-chart") if t["kind"] == "mean"]) == 2
    assert_local(page, server)


def test_compare_large_screen(browser, server, screenshots, two_jobs):
    a, b = two_jobs
    with page_at(browser, server, 2560, 1440) as pg:
        pg.goto(f"/#/compare?jobs={a},{b}")
        wait_rendered(pg, "#compare-chart")
        pg.screenshot(path=str(screenshots / "compare-2560.png"))


def test_runs_view_edit_filter_delete(page, server, screenshots, two_jobs):
    a, _ = two_jobs
    victim = api(server, "POST", "/jobs", {"system": "single", "seeds": 1, "episodes": 5, "name": "to delete"})
    wait_job(server, victim["id"])
    page.goto("/#/runs")
    row = page.locator(f'tr[data-id="{a}"]')
    row.wait_for()
    header = [h.strip(" ▲▼\n") for h in page.locator("table.runs thead th").all_inner_texts()]  # minus sort marks
    for col in ("Status", "System", "Configurations", "Seeds", "Episodes", "Tags", "Created", "Duration"):
        assert col in header
    page.screenshot(path=str(screenshots / "runs.png"), full_page=True)

    # Rename, tag and note through the dialog (PATCH).
    page.get_by_role("button", name=f"Edit name, tags and notes of job {a}").click()
    dialog = page.get_by_role("dialog")
    dialog.get_by_label("Name").fill("renamed A")
    dialog.get_by_label("Tags").fill("cmp, renamed")
    dialog.get_by_label("Notes").fill("a note")
    dialog.get_by_role("button", name="Save").click()
    page.locator(f'tr[data-id="{a}"] >> text=renamed A').wait_for()
    assert api(server, "GET", f"/jobs/{a}")["tags"] == ["cmp", "renamed"]

    # Filter by tag and by text.
    page.get_by_label("Tag", exact=True).fill("renamed")
    page.wait_for_function("() => document.querySelectorAll('table.runs tbody tr').length === 1")
    page.get_by_label("Tag", exact=True).fill("")
    page.get_by_label("Search").fill("no such job anywhere")
    page.get_by_text("No jobs match these filters.").wait_for()
    page.get_by_role("button", name="Clear filters").click()
    page.locator(f'tr[data-id="{victim["id"]}"]').wait_for()

    # Delete with confirmation: "Keep the job" does nothing, "Delete" removes the row and the job.
    page.get_by_role("button", name=f"Delete job {victim['id']}").click()
    page.get_by_role("dialog").get_by_role("button", name="Keep the job").click()
    assert page.locator(f'tr[data-id="{victim["id"]}"]').count() == 1
    page.get_by_role("button", name=f"Delete job {victim['id']}").click()
    page.get_by_role("dialog").get_by_role("button", name="Delete").click()
    page.locator(f'tr[data-id="{victim["id"]}"]').wait_for(state="detached")
    with pytest.raises(urllib.error.HTTPError) as err:
        api(server, "GET", f"/jobs/{victim['id']}")
    assert err.value.code == 404
    assert_local(page, server)


def test_cancel_from_job_view(page, server, screenshots):
    big = api(server, "POST", "/jobs", {"system": "large", "seeds": 30, "episodes": 5000, "name": "to cancel"})
    page.goto(f"/#/jobs/{big['id']}")
    page.get_by_role("button", name="Cancel job").click()
    page.get_by_role("dialog").get_by_role("button", name="Cancel job").click()
    page.get_by_text("This job was cancelled").wait_for()
    page.screenshot(path=str(screenshots / "job-cancelled.png"))
    assert_local(page, server)


def test_failed_job_shows_its_reason(page, server, screenshots):
    job = api(server, "POST", "/jobs", {"system": "single", "seeds": 1, "episodes": 5, "name": "will fail"})
    wait_job(server, job["id"])
    failed = {
        **api(server, "GET", f"/jobs/{job['id']}"),
        "status": "failed",
        "error": "ValueError: synthetic failure for the test",
    }
    # The API cannot be made to fail a job on purpose, so the job's JSON is answered as failed.
    page.route(f"**/api/jobs/{job['id']}", lambda route: route.fulfill(json=failed))
    page.goto(f"/#/jobs/{job['id']}")
    page.get_by_text("This job failed.").wait_for()
    assert "synthetic failure for the test" in page.locator(".error-text").inner_text()
    page.screenshot(path=str(screenshots / "job-failed.png"))
    assert_local(page, server)


def test_api_down_banner(page, server, screenshots):
    page.goto("/#/runs")
    page.locator("table.runs, .notice.empty").first.wait_for()
    page.route("**/api/**", lambda route: route.abort())
    page.goto("/#/compare?jobs=1")
    page.reload()
    banner = page.locator("#banner")
    banner.wait_for(state="visible")
    assert "Cannot reach" in banner.inner_text()
    page.screenshot(path=str(screenshots / "api-down.png"))


def test_unknown_job_and_keyboard_nav(page, server):
    page.goto("/#/jobs/999999")
    page.get_by_text("There is no job 999999.").wait_for()
    # After a route change focus sits on the view's heading, for keyboard and screen-reader users.
    assert page.evaluate("document.activeElement.tagName") == "H1"
    # The skip link is the first focusable element and jumps to <main> without breaking the route.
    page.goto("/#/runs")
    page.locator("table.runs, .notice.empty").first.wait_for()
    assert page.evaluate("document.querySelector('a[href], button, input, select').className") == "skip-link"
    page.focus(".skip-link")
    page.keyboard.press("Enter")
    assert page.evaluate("document.activeElement.id") == "main"
    assert page.url.endswith("#/runs")
    page.goto("/#/runs")
    page.get_by_role("link", name="New experiment").first.focus()
    page.keyboard.press("Enter")
    page.wait_for_url(re.compile("#/new"))
    expect(page.get_by_role("heading", name="New experiment")).to_be_visible()
    # Every form control has an accessible label.
    unlabelled = page.evaluate(
        """() => [...document.querySelectorAll('input, select, textarea')]
              .filter(el => !el.labels.length && !el.getAttribute('aria-label')).map(el => el.outerHTML)"""
    )
    assert unlabelled == []
    assert_local(page, server)
