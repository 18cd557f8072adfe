"""Follow every link of the rendered documentation pages of a running service (``/project-docs/``)."""

from __future__ import annotations

import urllib.error
import urllib.request
from html.parser import HTMLParser
from urllib.parse import urldefrag, urljoin, urlsplit

DOCS = "/project-docs/"


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()
        self.scripts = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = dict(attrs)
        if values.get("id"):
            self.ids.add(values["id"])
        if tag == "script":
            self.scripts += 1
        for name in ("href", "src"):
            if values.get(name):
                self.links.append(values[name])


def _get(url: str) -> tuple[int, str, dict[str, str]]:
    try:
        with urllib.request.urlopen(url, timeout=20) as answer:  # follows the .md -> .html redirect
            return answer.status, answer.read().decode("utf-8", "replace"), dict(answer.headers)
    except urllib.error.HTTPError as error:
        return error.code, "", dict(error.headers)


def crawl_docs(base: str) -> tuple[dict[str, _Links], list[str]]:
    """Every docs page reachable from the index, and what is wrong: a link (href or src) that does not
    answer 200, an anchor missing from its page, a script in a page. Returns ``({path: parsed}, problems)``."""
    pages: dict[str, _Links] = {}
    problems: list[str] = []
    checked: dict[str, int] = {}
    queue = [base + DOCS]
    while queue:
        url = queue.pop()
        path = urlsplit(url).path
        if path in pages:
            continue
        status, text, headers = _get(url)
        if status != 200 or "text/html" not in headers.get("content-type", ""):
            problems.append(f"{path}: {status} {headers.get('content-type')}")
            continue
        parsed = _Links()
        parsed.feed(text)
        pages[path] = parsed
        if parsed.scripts:
            problems.append(f"{path}: {parsed.scripts} script element(s)")
        for link in parsed.links:
            target = urljoin(url, link)
            if not target.startswith(base):
                continue  # another site: not ours to check
            address, _fragment = urldefrag(target)
            if address not in checked:
                checked[address] = _get(address)[0]
            if checked[address] != 200:
                problems.append(f"{path}: {link} answers {checked[address]}")
            elif urlsplit(address).path.startswith(DOCS) and urlsplit(address).path.endswith(".html"):
                queue.append(address)
    for path, parsed in list(pages.items()):
        for link in parsed.links:
            target, fragment = urldefrag(urljoin(base + path, link))
            target_path = urlsplit(target).path
            if fragment and target_path.startswith(DOCS) and target_path in pages:
                if fragment not in pages[target_path].ids:
                    problems.append(f"{path}: {link}: no id {fragment!r} in {target_path}")
    return pages, problems
