"""The project's docs as HTML pages (``/project-docs/``): every page of docs/ rendered, every link
between them working, links to source files outside docs/ as plain text, no script."""

from __future__ import annotations

import urllib.request
from pathlib import Path

from backend.api.docpages import page, render
from tests.support.docs_crawl import crawl_docs

ROOT = Path(__file__).resolve().parents[2]


def test_every_link_of_every_docs_page_answers_200_and_every_anchor_exists(live_server: str):
    pages, problems = crawl_docs(live_server)
    assert not problems, "\n".join(problems)
    expected = {f"/project-docs/{p.stem}.html" for p in (ROOT / "docs").glob("*.md")}
    assert expected | {"/project-docs/"} == set(pages)
    with urllib.request.urlopen(f"{live_server}/project-docs/reproduction.html", timeout=10) as answer:
        assert "script-src 'self'" in answer.headers["content-security-policy"]
        text = answer.read().decode()
    assert '<a href="model.html#environment-readings">model.md</a>' in text
    assert 'id="environment-readings"' in urllib.request.urlopen(f"{live_server}/project-docs/model.html",
                                                                 timeout=10).read().decode()
    with urllib.request.urlopen(f"{live_server}/project-docs/reproduction.md", timeout=10) as answer:
        assert answer.url.endswith("/project-docs/reproduction.html")  # the old address leads to the page


def test_links_outside_the_docs_become_plain_text(tmp_path: Path):
    docs = tmp_path / "docs"
    (docs / "img").mkdir(parents=True)
    (docs / "img" / "a.png").write_bytes(b"\x89PNG")
    (docs / "one.md").write_text(
        "# One: the first\n\nSee [two](two.md#far-away), [here](#one-the-first), [readme](../README.md), "
        "[gone](gone.md), [site](https://example.org/x) and ![pic](img/a.png) ![lost](img/b.png).\n\n"
        "## Far away\n", encoding="utf-8")
    (docs / "two.md").write_text("# Two\n\n## Far away\n\nBack to [one](./one.md).\n", encoding="utf-8")
    html = render(docs, "one").body.decode()
    assert '<a href="two.html#far-away">two</a>' in html
    assert '<a href="#one-the-first">here</a>' in html
    assert '<span class="source-ref" title="../README.md: in the project' in html and ">readme</span>" in html
    assert ">gone</span>" in html and 'href="gone' not in html
    assert '<a href="https://example.org/x">site</a>' in html
    assert 'src="img/a.png"' in html and "img/b.png" not in html
    assert '<h2 id="far-away">' in render(docs, "two").body.decode()
    assert '<a href="one.html">one</a>' in render(docs, "two").body.decode()
    assert ">One</a>" in html  # the navigation names each page by its title, up to a colon
    assert page(docs, "three") is None and page(docs, "../one") is None


def test_the_api_pages_schemathesis_command_is_a_code_block_of_its_own() -> None:
    # the paragraph after it ("Times are ISO 8601 UTC strings") once ran into the command (issue 30, item 9)
    html = render(ROOT / "docs", "api").body.decode()
    block = html[html.index("schemathesis run"):]
    block = block[: block.index("</code></pre>")]
    assert "Times are" not in block and "HYPOTHESIS_STORAGE_DIRECTORY" in html
    assert "<p>Times are ISO 8601 UTC strings." in html
