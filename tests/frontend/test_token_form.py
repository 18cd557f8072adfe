"""The dashboard against a server that protects its reads (MGRAO_PROTECT_READS): it asks for the token once.

A real `mgrao serve` with a token and protected reads, headless Chromium: the page's own form (not
window.prompt) asks for the token, sessionStorage keeps it for the tab, every API request carries
it, and a refused token is asked for again with a message that says so.
"""

from __future__ import annotations

import json
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest
from playwright.sync_api import expect

from tests.frontend.conftest import page_at, running_service

pytestmark = [pytest.mark.browser, pytest.mark.slow]

TOKEN = "dashboard-s3cret"

COUNT_ASKS = """
window.__asks = 0;
document.addEventListener('DOMContentLoaded', () => {
  const section = document.getElementById('token-ask');
  new MutationObserver(() => { if (!section.hidden) window.__asks += 1; })
    .observe(section, { attributes: true, attributeFilter: ['hidden'] });
});
"""


def api(base: str, method: str, path: str, body: dict | None = None) -> dict:
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(f"{base}/api{path}", data=data, method=method,
                                     headers={"Content-Type": "application/json", "Authorization": f"Bearer {TOKEN}"})
    with urllib.request.urlopen(request, timeout=30) as response:
        return json.loads(response.read())


def wait_succeeded(base: str, job_id: int, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        status = api(base, "GET", f"/jobs/{job_id}")["status"]
        if status == "succeeded":
            return
        assert status in ("queued", "running"), f"job {job_id} ended {status}"
        time.sleep(0.3)
    raise AssertionError(f"job {job_id} did not succeed within {timeout} s")


@pytest.fixture(scope="module")
def protected(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, int]]:
    """A protected service with one finished job: (base URL, job id)."""
    with running_service(tmp_path_factory.mktemp("protected"), workers=1, MGRAO_API_TOKEN=TOKEN,
                         MGRAO_PROTECT_READS="true") as base:
        job = api(base, "POST", "/jobs", {"system": "single", "seeds": 2, "episodes": 20, "name": "private job"})
        wait_succeeded(base, job["id"])
        yield base, job["id"]


@pytest.fixture
def watched(browser, protected):
    """A fresh page on the protected service recording its API requests' Authorization and any dialog."""
    base, _job = protected
    with page_at(browser, base) as page:
        page.api_calls = []  # type: ignore[attr-defined]
        page.dialogs = []  # type: ignore[attr-defined]
        page.on("request", lambda r: "/api/" in r.url and page.api_calls.append(
            (r.url, r.headers.get("authorization"))))
        page.on("dialog", lambda d: (page.dialogs.append(d.message), d.dismiss()))
        page.add_init_script(COUNT_ASKS)
        page.set_default_timeout(30000)
        yield page


def ask_form(page):
    form = page.get_by_role("region", name="API token needed")
    expect(form).to_be_visible()
    return form


def test_asks_once_keeps_the_token_for_the_session_and_lists_jobs(watched, protected, screenshots: Path):
    page = watched
    base, job_id = protected
    page.goto("/#/runs")
    form = ask_form(page)
    field = form.get_by_label("Bearer token (the server's MGRAO_API_TOKEN)")
    expect(field).to_be_focused()
    expect(form.get_by_role("alert")).to_contain_text("only with its API token")
    expect(page.locator("table.runs")).to_have_count(0)  # nothing shown without the token
    page.screenshot(path=str(screenshots / "token-form.png"), full_page=True)

    field.fill(TOKEN)
    form.get_by_role("button", name="Continue").click()
    expect(page.locator("table.runs")).to_contain_text("private job")
    expect(form).to_be_hidden()
    assert page.evaluate("() => sessionStorage.getItem('mgrao-api-token')") == TOKEN
    assert page.evaluate("() => localStorage.getItem('mgrao-api-token')") is None
    # the header's counts come from /api/health with the token (without it the server says only "ok")
    expect(page.locator("#health")).to_contain_text("queued", timeout=20000)

    first = len(page.api_calls)
    page.goto(f"/#/jobs/{job_id}")
    page.locator("#utility-chart[data-rendered]").wait_for()
    with page.expect_download() as download:  # a link cannot send the token: the page fetches the file
        page.get_by_role("link", name="Episodes as CSV").click()
    assert Path(download.value.path()).read_text().startswith("job_id,algorithm,seed,episode,utility")
    page.goto("/#/studies")
    page.locator("h1", has_text="Studies").wait_for()
    page.reload()  # a new page of the same tab: sessionStorage still has the token
    page.goto("/#/runs")
    expect(page.locator("table.runs")).to_contain_text("private job")
    assert page.evaluate("() => window.__asks") == 0  # not asked again after the reload
    sent = page.api_calls[first:]
    assert sent and all(auth == f"Bearer {TOKEN}" for _url, auth in sent), sent
    assert page.dialogs == []  # no window.prompt, alert or confirm


def test_a_wrong_token_is_asked_for_again(watched, protected, screenshots: Path):
    page = watched
    page.goto("/#/runs")
    form = ask_form(page)
    field = form.get_by_label("Bearer token (the server's MGRAO_API_TOKEN)")
    field.fill("not-the-token")
    field.press("Enter")
    expect(form.get_by_role("alert")).to_have_text("The server refused that token. Check it and enter it again.")
    expect(field).to_have_attribute("aria-invalid", "true")
    expect(field).to_be_focused()
    expect(field).to_have_value("")
    assert page.evaluate("() => sessionStorage.getItem('mgrao-api-token')") is None  # the refused one is forgotten
    page.screenshot(path=str(screenshots / "token-form-refused.png"), full_page=True)

    field.fill(TOKEN)
    form.get_by_role("button", name="Continue").click()
    expect(page.locator("table.runs")).to_contain_text("private job")
    expect(form).to_be_hidden()
    assert page.evaluate("() => window.__asks") == 2  # the first ask, and once more after the wrong token

    # a token changed on the server while the page is open: the next read asks again
    page.evaluate("() => sessionStorage.setItem('mgrao-api-token', 'rotated-away')")
    page.goto("/#/studies")
    expect(ask_form(page).get_by_role("alert")).to_contain_text("refused that token")
    field.fill(TOKEN)
    field.press("Enter")
    expect(page.locator("main h1")).to_have_text("Studies")
    expect(form).to_be_hidden()
    assert page.dialogs == []
