"""The project's documentation as HTML pages: ``/project-docs/`` (rendered server-side, no script).

The pages are ``docs/*.md`` as the installed :mod:`mgrao_docs` package holds them, rendered with
Python-Markdown (tables, fenced code, heading ids as GitHub makes them, so ``service.md#the-queue``
finds its heading). Links are rewritten so that every one of them works from the rendered page:

* ``other.md`` and ``other.md#anchor`` of a page in ``docs/`` → ``other.html`` (with the anchor);
* ``#anchor``, ``img/...`` and absolute ``http(s)://`` or ``mailto:`` addresses are kept;
* anything else (a source file outside ``docs/`` such as ``../README.md``, a page that does not
  exist) becomes plain text with a title saying where it is, instead of a link that answers 404.

Addresses: ``/project-docs/`` (an index of the pages), ``/project-docs/NAME.html``,
``/project-docs/img/FILE`` and ``/project-docs/NAME.md``, a permanent redirect to the page (the
address the paper view linked to before). A page carries the dashboard's header with a link back;
its styles are ``/style.css`` and ``/docpage.css``, and it holds no script (the service's
Content-Security-Policy allows none inline).
"""

from __future__ import annotations

import hashlib
import html
import mimetypes
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import urlsplit

import markdown
from fastapi import FastAPI, Request, Response
from fastapi.responses import RedirectResponse
from markdown.extensions import Extension
from markdown.treeprocessors import Treeprocessor

from mgrao_docs import docs_dir

PREFIX = "/project-docs"
REVALIDATE = "no-cache"
EXTERNAL = re.compile(r"^(https?:|mailto:)", re.IGNORECASE)
PAGE_NAME = re.compile(r"[a-z0-9][a-z0-9_-]*")


@dataclass
class Docs:
    """The pages and images of a docs directory, read once.

    What a service serves whatever happens to the files after it started (a reinstall removes the installed
    package's).
    """

    texts: dict[str, str]
    """Page name -> its Markdown."""
    images: dict[str, bytes]
    """File name under ``img/`` -> its bytes."""
    rendered: dict[str, Page] = field(default_factory=dict)

    @classmethod
    def read(cls, directory: Path) -> Docs:
        """Every page (``*.md`` with a page's name) and image (``img/*``) of ``directory``."""
        texts = {p.stem: p.read_text(encoding="utf-8") for p in sorted(directory.glob("*.md"))
                 if PAGE_NAME.fullmatch(p.stem)}
        folder = directory / "img"
        images = {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()} if folder.is_dir() else {}
        return cls(texts, images)


def _docs(source: Docs | Path) -> Docs:
    return source if isinstance(source, Docs) else Docs.read(source)


def page_names(source: Docs | Path) -> list[str]:
    """The pages: the stems of the ``*.md`` files, sorted."""
    return sorted(_docs(source).texts)


def page_title(text: str, name: str) -> str:
    """A page's title: its first level-1 heading, else its name."""
    match = re.search(r"^#\s+(.+)$", text, re.MULTILINE)
    return match.group(1).strip() if match else name


def titles(source: Docs | Path) -> dict[str, str]:
    """Every page's name and title, in name order."""
    docs = _docs(source)
    return {n: page_title(docs.texts[n], n) for n in sorted(docs.texts)}


def image_names(source: Docs | Path) -> list[str]:
    """The files of ``img/``, sorted."""
    return sorted(_docs(source).images)


def slugify(value: str, separator: str) -> str:
    """A heading's id as GitHub makes it: lower case, punctuation dropped, spaces as ``separator``."""
    value = re.sub(r"[^\w\s-]", "", value.strip().lower())
    return re.sub(r"\s", separator, value)


class _Links(Treeprocessor):
    """Rewrites ``<a href>`` and ``<img src>`` of one page (see the module docstring)."""

    def __init__(self, md: markdown.Markdown, pages: frozenset[str], images: frozenset[str]) -> None:
        super().__init__(md)
        self.pages, self.images = pages, images

    def target(self, address: str) -> str | None:
        """The rendered page's address for ``address``, or None when it leads to nothing served."""
        if EXTERNAL.match(address) or address.startswith("#"):
            return address
        parts = urlsplit(address)
        if parts.scheme or parts.netloc or parts.query:
            return None
        fragment = f"#{parts.fragment}" if parts.fragment else ""
        path = parts.path.removeprefix("./")
        if path.endswith(".md") and path[:-3] in self.pages:
            return f"{path[:-3]}.html{fragment}"
        if path.startswith("img/") and path[4:] in self.images:
            return path
        return None

    def run(self, root: ET.Element) -> None:
        """Rewrite in place: kept, re-addressed, or turned into a ``<span class="source-ref">``."""
        for parent in root.iter():
            for element in list(parent):
                if element.tag == "a" and element.get("href") is not None:
                    address = element.get("href", "")
                    target = self.target(address)
                    if target is not None:
                        element.set("href", target)
                    else:
                        element.tag = "span"
                        del element.attrib["href"]
                        element.set("class", "source-ref")
                        element.set("title", f"{address}: in the project's source tree, not a page of these docs")
                elif element.tag == "img":
                    target = self.target(element.get("src", ""))
                    if target is None:
                        parent.remove(element)
                    else:
                        element.set("src", target)


class _LinkExtension(Extension):
    def __init__(self, pages: frozenset[str], images: frozenset[str]) -> None:
        super().__init__()
        self.pages, self.images = pages, images

    def extendMarkdown(self, md: markdown.Markdown) -> None:  # noqa: N802 (Python-Markdown's name)
        """Run after the inline patterns have made the links (priority below 'inline')."""
        md.treeprocessors.register(_Links(md, self.pages, self.images), "mgrao_links", 5)


@dataclass(frozen=True)
class Page:
    """One rendered page: its title (the first heading) and the HTML document."""

    name: str
    title: str
    body: bytes
    etag: str


def render(source: Docs | Path, name: str) -> Page:
    """The HTML document of page ``name``, with its links made to work (module docstring)."""
    docs = _docs(source)
    pages = page_names(docs)
    text = docs.texts[name]
    md = markdown.Markdown(extensions=["tables", "fenced_code", "sane_lists", "toc",
                                       _LinkExtension(frozenset(pages), frozenset(image_names(docs)))],
                           extension_configs={"toc": {"slugify": slugify}}, output_format="html")
    article = md.convert(text)
    title = page_title(text, name)
    body = _document(title, article, titles(docs), current=name).encode()
    return Page(name, title, body, '"' + hashlib.sha256(body).hexdigest()[:32] + '"')


def _current(on: bool) -> str:
    return ' aria-current="page"' if on else ""


def _short(title: str) -> str:
    """A page's title up to its first colon or comma: "Studies: sweeps and searches" → "Studies"."""
    return re.split(r"[:,]", title, maxsplit=1)[0].strip()


def _document(title: str, article: str, pages: dict[str, str], current: str | None) -> str:
    nav = "".join(f'<li><a href="{n}.html"{_current(n == current)}>{html.escape(_short(t))}</a></li>'
                  for n, t in pages.items())
    return (
        '<!doctype html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)} · MG-RAO docs</title>\n"
        '<link rel="icon" href="/favicon.svg" type="image/svg+xml">\n'
        '<link rel="stylesheet" href="/style.css">\n<link rel="stylesheet" href="/docpage.css">\n</head>\n<body>\n'
        '<a class="skip-link" href="#main">Skip to content</a>\n'
        '<header class="site-header"><a class="brand" href="/#/runs">'
        '<img src="/favicon.svg" alt="" width="24" height="24"> MG-RAO</a>'
        '<nav aria-label="Main"><ul><li><a href="/#/runs">Dashboard</a></li>'
        f'<li><a href="{PREFIX}/"{_current(current is None)}>Docs</a></li></ul></nav>'
        "</header>\n"
        f'<div class="doc-layout"><nav class="doc-nav" aria-label="Documentation"><ul>{nav}</ul></nav>\n'
        f'<main id="main" class="doc-page" tabindex="-1">\n{article}\n</main></div>\n</body>\n</html>\n'
    )


def page(source: Docs | Path, name: str) -> Page | None:
    """The rendered page ``name`` (rendered once per snapshot), None if there is none."""
    docs = _docs(source)
    if name not in docs.texts:
        return None
    if name not in docs.rendered:
        docs.rendered[name] = render(docs, name)
    return docs.rendered[name]


def index(source: Docs | Path) -> bytes:
    """The index of the pages: each with its title."""
    pages = titles(source)
    items = "".join(f'<li><a href="{n}.html">{html.escape(t)}</a> <code>docs/{n}.md</code></li>'
                    for n, t in pages.items())
    article = ("<h1>Documentation</h1>\n<p>The project's <code>docs/</code>, as installed with this service.</p>\n"
               f'<ul class="doc-index">{items}</ul>')
    return _document("Documentation", article, pages, current=None).encode()


def _html(body: bytes, etag: str, request: Request) -> Response:
    headers = {"cache-control": REVALIDATE, "etag": etag}
    if etag in request.headers.get("if-none-match", ""):
        return Response(status_code=304, headers=headers)
    return Response(b"" if request.method == "HEAD" else body, media_type="text/html", headers=headers)


def install_docs(app: FastAPI, directory: Path | None = None) -> None:
    """The ``/project-docs/`` routes for the pages of ``directory`` (default: the installed docs), read at start."""
    directory = Docs.read(directory or docs_dir())
    missing = Response("No such page of the documentation.", status_code=404, media_type="text/plain")

    @app.api_route(PREFIX, methods=["GET", "HEAD"], include_in_schema=False)
    def docs_root() -> Response:
        return RedirectResponse(f"{PREFIX}/", status_code=308)

    @app.api_route(f"{PREFIX}/", methods=["GET", "HEAD"], include_in_schema=False)
    def docs_index(request: Request) -> Response:
        body = index(directory)
        return _html(body, '"' + hashlib.sha256(body).hexdigest()[:32] + '"', request)

    @app.api_route(PREFIX + "/{name}.html", methods=["GET", "HEAD"], include_in_schema=False)
    def docs_page(name: str, request: Request) -> Response:
        found = page(directory, name)
        return missing if found is None else _html(found.body, found.etag, request)

    @app.api_route(PREFIX + "/{name}.md", methods=["GET", "HEAD"], include_in_schema=False)
    def docs_markdown(name: str) -> Response:
        if name not in page_names(directory):
            return missing
        return RedirectResponse(f"{PREFIX}/{name}.html", status_code=308)

    @app.api_route(PREFIX + "/img/{file}", methods=["GET", "HEAD"], include_in_schema=False)
    def docs_image(file: str) -> Response:
        if file not in image_names(directory):
            return missing
        media_type = mimetypes.guess_type(file)[0] or "application/octet-stream"
        return Response(directory.images[file], media_type=media_type, headers={"cache-control": REVALIDATE})
