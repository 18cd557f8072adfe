"""The dashboard's pages for a job of 10,000 children (issue 42, item 4): the job page and compare render, the
weights show one child at a time (loaded alone) or the mean over every child, and say what each run stored.

Real `mgrao serve` with real worker processes, a real SQLite file, headless Chromium.
"""

from __future__ import annotations

import json
import urllib.request

from tests.frontend.conftest import page_at
from tests.frontend.test_job_view import post_job, wait_for

PARAMS = {"n_children": 10_000, "n_parents": 20_000, "topology": "ring", "children_per_parent": 4}
ALGORITHMS = ["uniform", "mgrao-100:1"]
BIGGEST_ANSWER = 6_000_000
"""Bytes of the largest answer the pages may read: a page of 100 children's weights, not 10,000 children's."""


def get(base: str, path: str) -> dict:
    with urllib.request.urlopen(f"{base}{path}", timeout=60) as response:
        return json.loads(response.read())


def bars(page) -> dict[str, list[float]]:
    return page.eval_on_selector("#weights-bars", "el => Object.fromEntries((el.data || []).map("
                                 "t => [t.meta.config, Array.from(t.y)]))")


def learner(answer: dict) -> dict:
    return next(c for c in answer["configurations"] if c["algorithm"] == "mgrao-100:1")


def test_the_pages_of_a_job_of_10000_children(browser, server, screenshots):
    job = post_job(server, {"system": "multi", "algorithms": ALGORITHMS, "seeds": [2, 5], "episodes": 3,
                            "params": PARAMS, "name": "10,000 children"})
    assert job.get("id"), job
    wait_for(lambda: get(server, f"/api/jobs/{job['id']}")["status"] == "succeeded", 600, "the large job to finish")
    first = get(server, f"/api/jobs/{job['id']}/weights?seed=2")
    far = get(server, f"/api/jobs/{job['id']}/weights?seed=2&child_offset=5000&children=1")

    with page_at(browser, server, 1280, 900) as page:
        sizes: dict[str, int] = {}
        page.on("response", lambda r: sizes.__setitem__(r.url, int(r.headers.get("content-length") or 0))
                if "/api/" in r.url else None)
        page.goto(f"/#/jobs/{job['id']}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        page.locator("#weights-bars .main-svg").first.wait_for()
        assert page.locator("table.summary tbody th").all_inner_texts() == ALGORITHMS

        # one seed, child 0, chosen by number: its combined weights and PW as stored; what a run keeps, said
        child = page.get_by_test_id("weights-child")
        assert child.get_attribute("type") == "number" and child.get_attribute("max") == "9999"
        wait_for(lambda: bars(page).get("mgrao-100:1") == learner(first)["combined"][0], 30, "child 0's weights")
        heat = page.eval_on_selector("#weights-heatmap", "el => el.data[0].z")
        assert heat == learner(first)["groups"][0]
        note = page.locator("#weights-children-note").inner_text()
        assert "10,000 children" in note and "parent-group weights of the first 1,000" in note
        page.locator("#h-w").scroll_into_view_if_needed()
        page.screenshot(path=str(screenshots / "weights-large-job.png"))

        # a child far in: loaded alone; its PW were not stored, and the view says why
        child.fill("5000")
        child.dispatch_event("change")
        wait_for(lambda: bars(page).get("mgrao-100:1") == learner(far)["combined"][0], 30, "child 5000's weights")
        assert any("child_offset=5000" in url and "children=1" in url for url in sizes)
        wait_for(lambda: "first 1,000 of 10,000 children" in page.locator("#weights-heat-note").inner_text(), 30,
                 "why child 5000's PW are not shown")
        assert page.locator("#weights-heatmap").is_hidden()

        # the mean over every child, stored with each run
        page.get_by_test_id("weights-children").select_option("all")
        mean = learner(far)["mean_over_children"]
        wait_for(lambda: bars(page).get("mgrao-100:1") == mean["combined"][0], 30, "the mean over children")
        assert page.eval_on_selector("#weights-heatmap", "el => el.data[0].z") == mean["groups"][0]
        assert "mean over all 10,000 children" in page.locator("#weights-heat-note").inner_text()
        assert child.is_disabled()

        # the mean over seeds covers the first page of children, and says so
        page.get_by_test_id("weights-children").select_option("one")
        page.get_by_test_id("weights-seed").select_option("mean")
        wait_for(lambda: "covers the first 100 children" in page.locator("#weights-children-note").inner_text(), 30,
                 "what the mean over seeds covers")
        assert child.get_attribute("max") == "99" and child.input_value() == "99"
        assert max(sizes.values()) < BIGGEST_ANSWER, sizes

    with page_at(browser, server) as page:
        page.goto(f"/#/compare?jobs={job['id']}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        traces = page.eval_on_selector("#compare-chart", "el => el.data.filter(t => t.meta && t.meta.kind === "
                                                         "'mean').map(t => t.meta.config)")
        assert len(traces) == 2 and all(any(a in t for t in traces) for a in ALGORITHMS), traces
        page.screenshot(path=str(screenshots / "compare-large-job.png"))
