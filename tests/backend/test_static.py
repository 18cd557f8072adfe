"""Static files: HEAD, gzip, a year of caching for versioned libraries, revalidation for the dashboard."""

from __future__ import annotations

import gzip
import re

import httpx
import pytest
from fastapi.testclient import TestClient

from backend.api.static import dashboard_digest, docs_asset_url, docs_assets_dir, frontend_dir, plotly_js, plotly_url

IDENTITY = {"Accept-Encoding": "identity"}
GZIP = {"Accept-Encoding": "gzip"}
DASHBOARD_FILES = ["/", "/index.html", "/js/app.js", "/js/charts.js", "/js/api.js", "/style.css", "/favicon.svg"]


@pytest.mark.one_database
def test_plotly_is_served_under_its_version(client: TestClient) -> None:
    import hashlib

    from plotly.offline import get_plotlyjs_version

    url = plotly_url()  # the dashboard's partial bundle: its plotly.js version and the start of its sha256
    digest = hashlib.sha256(plotly_js().read_bytes()).hexdigest()
    assert url == f"/vendor/plotly-dashboard-{get_plotlyjs_version()}-{digest[:12]}.min.js"
    response = client.get(url, headers=IDENTITY)
    assert response.status_code == 200 and response.content == plotly_js().read_bytes()
    assert response.headers["content-type"].startswith("text/javascript")
    assert response.headers["cache-control"] == "public, max-age=31536000, immutable"
    assert "content-encoding" not in response.headers
    assert client.get("/vendor/plotly-0.0.1.min.js").status_code == 404


@pytest.mark.one_database
def test_plotly_gzip_when_accepted(client: TestClient) -> None:
    raw = plotly_js().read_bytes()
    with client.stream("GET", plotly_url(), headers=GZIP) as response:
        body = b"".join(response.iter_raw())
    assert response.status_code == 200
    assert response.headers["content-encoding"] == "gzip" and "Accept-Encoding" in response.headers["vary"]
    assert int(response.headers["content-length"]) == len(body) < len(raw) * 0.4
    assert gzip.decompress(body) == raw
    assert response.headers["cache-control"] == "public, max-age=31536000, immutable"


@pytest.mark.one_database
def test_old_plotly_address_redirects_to_the_versioned_one(client: TestClient) -> None:
    response = client.get("/vendor/plotly.min.js", follow_redirects=False)
    assert response.status_code == 307 and response.headers["location"] == plotly_url()
    assert response.headers["cache-control"] == "no-cache"
    followed = client.get("/vendor/plotly.min.js", headers=IDENTITY)
    assert followed.status_code == 200 and followed.content == plotly_js().read_bytes()


@pytest.mark.one_database
def test_versioned_files_revalidate_by_etag(client: TestClient) -> None:
    for url in (plotly_url(), docs_asset_url("swagger-ui-bundle.js")):
        etag = client.head(url).headers["etag"]
        response = client.get(url, headers={"If-None-Match": etag})
        assert response.status_code == 304 and response.content == b""


@pytest.mark.one_database
@pytest.mark.parametrize("encoding", [IDENTITY, GZIP])
def test_head_answers_every_static_file(client: TestClient, encoding: dict) -> None:
    urls = [*DASHBOARD_FILES, plotly_url(), "/vendor/plotly.min.js", docs_asset_url("swagger-ui-bundle.js"),
            docs_asset_url("swagger-ui.css"), "/docs", "/docs/swagger-init.js", "/openapi.json"]
    for url in urls:
        head = client.head(url, headers=encoding)
        assert head.status_code == 200, (url, head.status_code)
        assert head.content == b""
        get = client.get(url, headers=encoding)
        assert head.headers["content-type"] == get.headers["content-type"], url
        assert int(head.headers["content-length"]) > 0


@pytest.mark.one_database
@pytest.mark.parametrize("url", DASHBOARD_FILES)
def test_dashboard_files_revalidate(client: TestClient, url: str) -> None:
    response = client.get(url)
    assert response.status_code == 200
    assert response.headers["cache-control"] == "no-cache"
    etag = response.headers["etag"]
    again = client.get(url, headers={"If-None-Match": etag})
    assert again.status_code == 304 and again.headers["cache-control"] == "no-cache"


@pytest.mark.one_database
def test_index_names_the_versioned_plotly(client: TestClient) -> None:
    html = client.get("/").text
    assert re.search(r'<link rel="prefetch" id="plotly-src" href="([^"]+)" as="script">', html)[1] == plotly_url()
    assert "/vendor/plotly.min.js" not in html
    assert client.get("/index.html").text == html
    static = frontend_dir()
    assert static is not None and 'href="/vendor/plotly.min.js"' in (static / "index.html").read_text()


@pytest.mark.one_database
@pytest.mark.parametrize("url", ["/js/app.js", "/js/job.js", "/style.css", "/", "/openapi.json"])
def test_text_is_gzipped_when_accepted(client: TestClient, url: str) -> None:
    plain = client.get(url, headers=IDENTITY)
    assert "content-encoding" not in plain.headers
    with client.stream("GET", url, headers=GZIP) as response:
        body = b"".join(response.iter_raw())
    assert response.headers["content-encoding"] == "gzip"
    assert gzip.decompress(body) == plain.content and len(body) < len(plain.content)


def test_api_answers_are_not_compressed(client: TestClient) -> None:
    for url in ("/api/systems", "/api/jobs"):
        response = client.get(url, headers=GZIP)
        assert response.status_code == 200 and "content-encoding" not in response.headers


@pytest.mark.one_database
def test_docs_assets_come_from_fastapi_offline(client: TestClient) -> None:
    for name in ("swagger-ui-bundle.js", "swagger-ui.css"):
        response = client.get(docs_asset_url(name), headers=IDENTITY)
        assert response.status_code == 200 and response.content == (docs_assets_dir() / name).read_bytes()
        assert response.headers["cache-control"] == "public, max-age=31536000, immutable"
    page = client.get("/docs").text
    assert docs_asset_url("swagger-ui-bundle.js") in page and docs_asset_url("swagger-ui.css") in page
    assert "<script>" not in page and "http" not in page.replace('"http://www.w3.org', "")
    assert client.get("/redoc", follow_redirects=False).headers["location"] == "/docs"


def test_real_server_head_and_gzip(live_server: str) -> None:
    raw = plotly_js().read_bytes()
    with httpx.Client(base_url=live_server, timeout=60) as http:
        for url in ("/", "/js/app.js", "/style.css", plotly_url(), docs_asset_url("swagger-ui-bundle.js")):
            head = http.head(url, headers=IDENTITY)
            assert head.status_code == 200 and head.content == b"", url
            assert int(head.headers["content-length"]) == len(http.get(url, headers=IDENTITY).content), url
        assert http.head("/vendor/plotly.min.js").status_code == 307
        with http.stream("GET", plotly_url(), headers=GZIP) as response:
            body = b"".join(response.iter_raw())
        assert response.headers["content-encoding"] == "gzip" and gzip.decompress(body) == raw
        assert response.headers["cache-control"] == "public, max-age=31536000, immutable"
        assert http.get("/js/app.js").headers["cache-control"] == "no-cache"


@pytest.mark.one_database
def test_gzip_refused_with_q_zero_is_not_sent(client) -> None:
    response = client.get("/js/app.js", headers={"Accept-Encoding": "gzip;q=0"})
    assert response.status_code == 200 and "content-encoding" not in response.headers


@pytest.mark.one_database
def test_index_preloads_every_module_of_the_dashboard(client: TestClient) -> None:
    # all at once, instead of a level of imports at a time, each revalidated before the next is found
    html = client.get("/").text
    preloaded = re.findall(r'<link rel="modulepreload" href="/v/[0-9a-f]{16}/js/([^"]+)">', html)
    assert preloaded and sorted(preloaded) == sorted(p.name for p in (frontend_dir() / "js").glob("*.js"))
    prefix = re.search(r'href="(/v/[0-9a-f]{16})/js/', html).group(1)
    for name in preloaded:
        assert client.get(f"{prefix}/js/{name}").status_code == 200


@pytest.mark.one_database
def test_the_dashboard_is_named_under_its_digest_and_cached_there_for_a_year(client: TestClient) -> None:
    # A full reload then asks for index.html (revalidated) and the data alone, not for 25 modules.
    html = client.get("/").text
    digest = dashboard_digest(frontend_dir())
    for name in ("js/app.js", "style.css", "favicon.svg"):
        assert f'"/v/{digest}/{name}"' in html
        response = client.get(f"/v/{digest}/{name}", headers=IDENTITY)
        assert response.status_code == 200
        assert response.content == (frontend_dir() / name).read_bytes()
        assert response.headers["cache-control"] == "public, max-age=31536000, immutable"
    assert '"/js/app.js"' not in html and '"/style.css"' not in html
    # Another digest (a page from before an upgrade) gets today's file, to be revalidated.
    stale = client.get("/v/0000000000000000/js/app.js", headers=IDENTITY)
    assert stale.status_code == 200 and stale.headers["cache-control"] == "no-cache"
    for missing in (f"/v/{digest}/js/none.js", f"/v/{digest}", f"/v/{digest}/", f"/v/{digest}/../pyproject.toml"):
        assert client.get(missing).status_code == 404, missing


def test_the_digest_follows_every_versioned_file(tmp_path) -> None:
    (tmp_path / "js").mkdir()
    (tmp_path / "js" / "a.js").write_text("export const a = 1;")
    (tmp_path / "style.css").write_text("body {}")
    before = dashboard_digest(tmp_path)
    (tmp_path / "js" / "a.js").write_text("export const a = 2;")
    assert dashboard_digest(tmp_path) != before
    (tmp_path / "js" / "a.js").write_text("export const a = 1;")
    assert dashboard_digest(tmp_path) == before
    (tmp_path / "js" / "b.js").write_text("")
    assert dashboard_digest(tmp_path) != before
