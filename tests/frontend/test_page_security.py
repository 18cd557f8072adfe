"""Every page of the product works under the server's Content-Security-Policy and stays on 127.0.0.1."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import urlparse

import pytest
from test_dashboard import api, assert_local, wait_job, wait_rendered

pytestmark = [pytest.mark.browser, pytest.mark.slow]

REPORT_VIOLATIONS = """
document.addEventListener('securitypolicyviolation', (e) => window.__cspViolation(
  `${e.effectiveDirective} blocked ${e.blockedURI || '(inline)'} in ${e.sourceFile || e.documentURI}:${e.lineNumber}`));
"""


@pytest.fixture
def watched(page):
    """The dashboard fixture's page, also recording CSP violations, console and page errors, failed answers."""
    page.problems = []  # type: ignore[attr-defined]
    page.expose_function("__cspViolation", lambda text: page.problems.append(f"CSP violation: {text}"))
    page.add_init_script(REPORT_VIOLATIONS)
    page.on("console", lambda m: m.type == "error" and page.problems.append(f"console error: {m.text}"))
    page.on("pageerror", lambda e: page.problems.append(f"page error: {e}"))
    page.on("response", lambda r: r.status >= 400 and page.problems.append(f"{r.status} for {r.url}"))
    return page


@pytest.fixture(scope="module")
def finished_job(server) -> int:
    job = api(server, "POST", "/jobs", {"system": "single", "seeds": 2, "episodes": 30, "name": "csp check"})
    assert wait_job(server, job["id"])["status"] == "succeeded"
    return job["id"]


def test_dashboard_needs_nothing_the_csp_blocks(watched, server, finished_job):
    page = watched
    csp = page.goto("/").headers["content-security-policy"]
    assert "script-src 'self';" in csp and "unsafe-eval" not in csp
    page.locator("table.runs, .notice.empty").first.wait_for()

    page.goto(f"/#/jobs/{finished_job}")
    wait_rendered(page, "#utility-chart")
    page.locator("#weights-bars .main-svg").first.wait_for()
    # Plot export (the mode bar's camera) draws the SVG into a canvas through data: and blob: images.
    png = page.evaluate("() => Plotly.toImage(document.querySelector('#utility-chart'), {format: 'png'})")
    assert png.startswith("data:image/png;base64,") and len(png) > 1000
    buttons = page.eval_on_selector_all("#utility-chart .modebar-btn", "bs => bs.map(b => b.dataset.title)")
    assert "Download plot" in buttons  # as SVG (charts.js CONFIG), for papers
    page.hover("#utility-chart")
    with page.expect_download() as download:
        page.locator("#utility-chart .modebar-btn[data-title='Download plot']").click()
    assert download.value.suggested_filename.endswith(".svg")
    assert "<svg" in Path(download.value.path()).read_text()[:2000]

    # plotly.js came from its versioned address (cached for a year), named by index.html.
    src = page.get_attribute("#plotly-src", "href")
    assert re.fullmatch(r"/vendor/plotly-dashboard-\d+\.\d+\.\d+-[0-9a-f]{12}\.min\.js", src)  # the partial bundle
    assert page.get_attribute("#plotly-js", "src") == src
    assert server + src in page.requests and server + "/vendor/plotly.min.js" not in page.requests

    page.goto(f"/#/compare?jobs={finished_job}")
    wait_rendered(page, "#compare-chart")
    page.goto("/#/new")
    page.get_by_role("button", name="Run experiment").wait_for()
    page.get_by_role("link", name="Runs").first.click()
    page.locator("table.runs").wait_for()
    assert page.problems == []
    assert_local(page, server)


def test_api_docs_render_offline_under_the_csp(watched, server, finished_job):
    page = watched
    page.goto("/")
    page.locator("table.runs, .notice.empty").first.wait_for()
    page.goto(f"/#/jobs/{finished_job}")
    wait_rendered(page, "#utility-chart")
    buttons = page.eval_on_selector_all("#utility-chart .modebar-btn", "bs => bs.map(b => b.dataset.title)")
    assert "Download plot" in buttons
    assert not [b for b in buttons if "Share" in b]  # plotly.js's upload to its cloud is not offered

    # The footer's link leads to Swagger UI, drawn from local assets: the operations are listed.
    page.get_by_role("link", name="API docs").click()
    page.wait_for_url(re.compile(r"/docs$"))
    submit = page.locator(".opblock-post").filter(has=page.locator("[data-path='/api/jobs']"))
    submit.locator(".opblock-summary-description", has_text=re.compile(r"^Submit Job$")).wait_for()
    assert submit.locator(".opblock-summary-method").inner_text() == "POST"
    assert page.get_by_text("/api/jobs/{job_id}/cancel").first.is_visible()
    submit.locator(".opblock-summary-control").first.click()  # expand: parameters and schemas render
    submit.get_by_text("Request body").first.wait_for()

    # FastAPI's other page, ReDoc, always loads its vendor's logo from outside: /redoc leads to /docs.
    page.goto("/redoc")
    page.wait_for_url(re.compile(r"/docs$"))
    page.locator(".opblock-summary-description", has_text=re.compile(r"^Submit Job$")).wait_for()

    assert page.problems == []
    assert_local(page, server)
    hosts = {urlparse(u).hostname for u in page.requests if u.startswith("http")}
    assert hosts == {"127.0.0.1"}
    paths = {urlparse(u).path for u in page.requests}
    assert {"/docs", "/openapi.json", "/docs/swagger-init.js"} <= paths
