"""The compare view's statistics across systems, as a researcher reads them before publishing (issue 29): the
seeds each figure stands on, the score anchors, aggregates with intervals, performance profiles, the
head-to-head matrices, sample-efficiency curves on demand, and the paper-ready LaTeX and CSV."""

from __future__ import annotations

import json
import urllib.request
from pathlib import Path

from mgrao_client import Client
from tests.frontend.conftest import page_at
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_job_view import post_job

ALGORITHMS = ["uniform", "mgrao-1:1", "mgrao-max", "oracle"]


def test_the_statistics_panel_shows_every_statistic_and_its_seeds(browser, server, screenshots):
    jobs = [post_job(server, {"system": system, "algorithms": ALGORITHMS, "seeds": 10, "episodes": 40,
                              "name": f"{system} for statistics"}) for system in ("single", "large")]
    wait_succeeded(server, jobs)
    # a learner logged from outside on seeds 5-14 of single: 5 of its 10 seeds pair with the built-in uniform
    with urllib.request.urlopen(f"{server}/api/jobs/{jobs[0]['id']}/episodes?format=json", timeout=60) as answer:
        rows = json.loads(answer.read())
    uniform = {}
    for row in rows:
        if row["algorithm"] == "uniform":
            uniform.setdefault(row["seed"], []).append(row["utility"])
    run = Client(server).open_run(label="my-learner", system="single", episodes=40, seeds=list(range(5, 15)))
    for seed in range(5, 15):
        run.log(seed, [1.15 * u for u in uniform[seed % 10]])
    external = run.close()["job"]["id"]
    ids = ",".join(str(i) for i in (jobs[0]["id"], jobs[1]["id"], external))
    with page_at(browser, server, height=1000) as page:
        page.goto(f"/#/compare?jobs={ids}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        # the seeds each figure stands on: n_paired beside n_runs, a partial overlap marked
        row = page.locator("#pooled-table tbody tr", has_text="my-learner")
        assert "5 of 10" in row.locator("td.paired").inner_text() and "◐" in row.inner_text()
        assert "only some seeds pair with uniform" in page.inner_text("#pairing-notes")
        page.locator("#stats-body[data-loaded]").wait_for()
        anchors = page.inner_text("#anchors-table")
        assert "single" in anchors and "large" in anchors
        aggregates = page.locator("#aggregates-table tbody tr")
        assert aggregates.count() == 4  # my-learner has no large runs: left out of the aggregates, saying why
        assert "my-learner: not aggregated" in page.inner_text("#excluded-list")
        note = page.inner_text("#aggregated-note")
        assert "Aggregates over 2 systems, each on its anchor seeds" in note and "single: 10 seeds, 0–9" in note
        assert "single, my-learner: seeds 10–14 not scored (no uniform or oracle run" in page.inner_text(
            "#left-out-list")
        oracle = page.locator("#aggregates-table tbody tr", has_text="oracle").inner_text()
        assert "1.000 [" in oracle  # the oracle's mean score is 1 by definition
        for chart in ("#stats-intervals", "#stats-profiles", "#stats-poi", "#stats-differences"):
            page.locator(chart).scroll_into_view_if_needed()
            page.locator(f"{chart}[data-rendered]").wait_for()
        poi = page.eval_on_selector("#stats-poi", "el => el.data[0]")
        assert poi["type"] == "heatmap" and poi["x"] == ALGORITHMS and poi["z"][0][0] is None
        assert poi["z"][3][0] > 0.5 and abs(poi["z"][0][3] + poi["z"][3][0] - 1) < 1e-12  # the oracle tends to win
        differences = page.eval_on_selector("#stats-differences", "el => el.data[0]")
        assert "my-learner" in differences["x"]  # single's paired tests include the learner logged from outside
        page.locator("#stats-aggregates").screenshot(path=str(screenshots / "compare-statistics-aggregates.png"))
        page.locator("#stats-profile").screenshot(path=str(screenshots / "compare-statistics-profiles.png"))
        page.locator("#stats-head-to-head").screenshot(path=str(screenshots / "compare-statistics-head-to-head.png"))
        # sample-efficiency curves on demand
        page.locator("#efficiency-button").click()
        page.locator("#stats-efficiency[data-rendered]").wait_for()
        curves = page.eval_on_selector("#stats-efficiency", "el => el.data.filter(t => t.meta.kind === 'mean')"
                                                          ".map(t => t.name)")
        assert curves == ALGORITHMS
        page.locator("#stats-sample-efficiency").screenshot(
            path=str(screenshots / "compare-statistics-sample-efficiency.png"))
        # the paper-ready table: LaTeX with the protocol as its caption, and numbers in the CSV
        with page.expect_download() as download:
            page.locator("a.stats-latex").click()
        latex = Path(download.value.path()).read_text()
        assert "\\begin{tabular}" in latex and "10,000 repetitions" in latex
        with page.expect_download() as download:
            page.locator("a.stats-csv").click()
        csv_text = Path(download.value.path()).read_text()
        assert csv_text.startswith("# single:") and "n_paired" in csv_text
        # folded away, the panel is remembered in the address and asks nothing until it is opened again
        page.locator("#stats-panel > summary").click()
        page.wait_for_function("() => location.hash.includes('stats=0')")
        page.screenshot(path=str(screenshots / "compare-statistics.png"), full_page=True)


def test_a_system_in_two_worlds_is_aggregated_in_the_world_chosen(browser, server):
    specs = [("single", 20), ("single", 30), ("large", 20)]
    jobs = [post_job(server, {"system": system, "algorithms": ["uniform", "mgrao-1:1", "oracle"], "seeds": 4,
                              "episodes": episodes}) for system, episodes in specs]
    wait_succeeded(server, jobs)
    ids = ",".join(str(j["id"]) for j in jobs)
    with page_at(browser, server, height=1000) as page:
        page.goto(f"/#/compare?jobs={ids}")
        page.locator("#stats-body[data-loaded]").wait_for()
        assert "several worlds of one system" in page.inner_text("#stats-body")
        assert page.locator("#aggregates-table").count() == 0
        loaded = page.get_attribute("#stats-body", "data-loaded")
        page.select_option("#aggregate-single", label="single (episodes=30)")
        page.wait_for_function("before => document.querySelector('#stats-body').dataset.loaded !== before", arg=loaded)
        page.locator("#aggregates-table").wait_for()
        assert "Aggregates over 2 systems" in page.inner_text("#aggregated-note")
        assert "single (episodes=30): 4 seeds" in page.inner_text("#aggregated-note")
        assert page.eval_on_selector("#aggregate-single", "el => el.selectedOptions[0].text") == "single (episodes=30)"
        assert f"aggregate={jobs[1]['id']}" in page.get_attribute("a.stats-latex", "href")
