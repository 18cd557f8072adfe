"""The project's docs reached from the dashboard: the header's Docs link and the paper view's link to
the reproduction notes open rendered HTML pages (no raw Markdown), whose links lead between them."""

from __future__ import annotations

from tests.frontend.conftest import page_at


def test_docs_open_as_html_pages_from_the_header_and_the_paper_view(browser, server, screenshots):
    with page_at(browser, server) as page:
        problems = []
        page.on("pageerror", lambda error: problems.append(str(error)))
        page.on("console", lambda m: problems.append(m.text) if m.type == "error" else None)  # CSP reports here
        page.goto("/#/runs")
        page.click("#docs-link")
        page.wait_for_url("**/project-docs/")
        assert page.inner_text("main h1") == "Documentation"
        titles = page.locator("main .doc-index a").all_inner_texts()
        assert "Reproducing the paper's tables" in titles and "The experiment service" in titles
        page.screenshot(path=str(screenshots / "docs-index.png"))

        page.goto("/#/paper")
        page.click("#reproduction-doc")
        page.wait_for_url("**/project-docs/reproduction.html")
        assert page.inner_text("main h1") == "Reproducing the paper's tables"
        assert "# Reproducing" not in page.inner_text("main")  # rendered, not raw Markdown
        assert page.locator("main table").count() >= 1  # the Markdown tables are tables
        page.screenshot(path=str(screenshots / "docs-reproduction.png"))
        page.click('main a[href="model.html#environment-readings"]')
        page.wait_for_url("**/project-docs/model.html#environment-readings")
        assert page.locator("#environment-readings").is_visible()  # the anchor's heading is there
        page.goto("/project-docs/studies.html")
        images = page.locator("main img")
        assert images.count() == 2
        assert all(page.evaluate("img => img.complete && img.naturalWidth > 0", images.nth(i).element_handle())
                   for i in range(2)), "a docs image did not load"
        page.screenshot(path=str(screenshots / "docs-studies.png"))
        page.click('header a[href="/#/runs"]')
        page.wait_for_url("**/#/runs")
        assert not problems, problems
