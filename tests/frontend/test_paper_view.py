"""The "ours against the paper" view: the paper's tables beside our newest paper runs, each figure
flagged where the published value lies outside our 95% interval, with the reproduction notes linked."""

from __future__ import annotations

import json
import urllib.request

from tests.frontend.conftest import page_at
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_job_view import post_job


def test_ours_against_the_paper(browser, server, screenshots):
    with urllib.request.urlopen(f"{server}/api/systems", timeout=30) as answer:
        systems = json.loads(answer.read())["systems"]
    jobs = [post_job(server, {"system": s["name"], "algorithms": s["algorithms"], "seeds": 8, "episodes": 100,
                              "tags": ["paper"], "name": f"paper {s['name']}"}) for s in systems]
    wait_succeeded(server, jobs)
    with page_at(browser, server) as page:
        errors = []
        page.on("pageerror", lambda error: errors.append(error))
        page.goto("/#/paper")
        page.locator("#paper-table").wait_for()
        rows = page.locator("#paper-table tbody tr")
        expected = sum(len(s["paper"]) for s in systems)
        assert rows.count() == expected
        flags = page.locator("#paper-table td.flag").all_inner_texts()
        assert set(flags) <= {"within", "⚑ outside"} and len(flags) == expected  # every figure judged
        outside = page.locator("#paper-table tr.outside").count()
        assert f"{expected - outside} of {expected} figures" in page.inner_text("#paper-agreement")
        first = rows.first
        assert first.get_attribute("data-system") == systems[0]["name"]
        assert first.locator("a").get_attribute("href").startswith("#/jobs/")
        doc = page.get_attribute("#reproduction-doc", "href")
        with urllib.request.urlopen(f"{server}{doc}", timeout=30) as answer:
            assert answer.status == 200 and b"reproduc" in answer.read().lower()
        page.screenshot(path=str(screenshots / "paper.png"), full_page=True)
        assert not errors


def api_get(server: str, path: str):
    with urllib.request.urlopen(f"{server}{path}", timeout=30) as answer:
        return json.loads(answer.read())


def among_seeds_text(values: list[float], paper: float) -> str:
    """The cell "Paper among our seeds" should show, worked out here from the API's per-seed values."""
    below = sum(v < paper for v in values)
    above = sum(v > paper for v in values)
    if below == 0 and above:
        return f"below all {len(values)}"
    if above == 0 and below:
        return f"above all {len(values)}"
    n = round(100 * (below + (len(values) - below - above) / 2) / len(values))
    suffix = "th" if 11 <= n % 100 <= 13 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix} percentile"


def test_a_smaller_tagged_clone_never_replaces_the_paper_job_and_the_paper_is_placed_among_our_seeds(
        browser, server, screenshots):
    single = next(s for s in api_get(server, "/api/systems")["systems"] if s["name"] == "single")
    body = {"system": "single", "algorithms": single["algorithms"], "episodes": 100, "name": "paper single, many seeds"}
    big = post_job(server, body | {"seeds": 120})  # more seeds than any other test's paper-configuration job
    wait_succeeded(server, [big])
    # "Clone into a new experiment" keeps the tags: a newer 10-seed copy tagged "paper", and a tagged job
    # with a changed parameter; neither is the paper's experiment at its fullest
    clone = post_job(server, body | {"seeds": 10, "tags": ["paper"], "name": "clone of the paper job"})
    changed = post_job(server, body | {"seeds": 150, "tags": ["paper"], "params": {"learning_rate": 0.5}})
    wait_succeeded(server, [clone, changed])
    results = api_get(server, f"/api/jobs/{big['id']}/results?points=10&pct_by_seed=true")
    with page_at(browser, server) as page:
        errors = []
        page.on("pageerror", lambda error: errors.append(error))
        page.goto("/#/paper")
        page.locator("#paper-table").wait_for()
        row = page.locator('#paper-table tr[data-system="single"][data-algorithm="mgrao-max"]')
        link = row.locator("td").nth(1).locator("a")  # the Job column
        assert link.inner_text() == f"#{big['id']}", "the single rows must use the 120-seed job, not the newer clone"
        assert link.get_attribute("href") == f"#/jobs/{big['id']}"
        assert row.locator("td").nth(2).inner_text() == "120"  # the Seeds column
        for algorithm, paper in single["paper"].items():
            config = next(c for c in results["configurations"] if c["algorithm"] == algorithm)
            values = [p["pct_from_uniform"] for p in config["pct_by_seed"]]
            assert len(values) == 120
            cell = page.locator(f'#paper-table tr[data-system="single"][data-algorithm="{algorithm}"] td.seed-rank')
            assert cell.inner_text() == among_seeds_text(values, paper), algorithm
            assert "of our 120 seeds lie below the paper" in cell.get_attribute("title")
        assert "how many runs" in page.inner_text("#paper-seeds-help")
        page.screenshot(path=str(screenshots / "paper-seeds.png"), full_page=True)
        link.click()
        page.wait_for_url(f"**/#/jobs/{big['id']}", timeout=30000)  # the row's job opens
        assert not errors
