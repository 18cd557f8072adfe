"""Compare as a researcher reads it: one chart per system, configurations labelled by what differs
between them (with a table of the differences), one colour per configuration of a chart, a smoothing
that says what it is; uniform pooled over the jobs of one world, whatever their learners' parameters."""

from __future__ import annotations

import math
import time
from pathlib import Path

from tests.frontend.conftest import page_at
from tests.frontend.test_job_view import get_job, post_job


def wait_succeeded(server: str, jobs: list[dict]) -> None:
    deadline = time.monotonic() + 180
    while any(get_job(server, j["id"])["status"] != "succeeded" for j in jobs):
        assert time.monotonic() < deadline, "jobs did not finish"
        time.sleep(0.3)


def mean_traces(page, selector: str) -> list[dict]:
    return page.eval_on_selector(selector, """el => el.data.filter(t => t.meta && t.meta.kind === 'mean')
        .map(t => ({config: t.meta.config, color: t.line.color, dash: t.line.dash}))""")


def test_compare_facets_by_system_and_labels_by_difference(browser, server, screenshots):
    base = {"algorithms": ["uniform", "mgrao-max"], "seeds": 3, "episodes": 60, "tags": ["facets"]}
    jobs = [post_job(server, base | {"system": "single", "name": "single default"}),
            post_job(server, base | {"system": "single", "params": {"learning_rate": 0.09}, "name": "single lr"}),
            post_job(server, base | {"system": "large", "name": "large default"})]
    wait_succeeded(server, jobs)
    with page_at(browser, server) as page:
        page.goto(f"/#/compare?jobs={','.join(str(j['id']) for j in jobs)}&smooth=11")
        page.locator("#compare-chart[data-rendered]").wait_for()
        page.locator("main[data-all-drawn-ms]").wait_for()  # every chart, those below the fold too
        page.locator("#compare-chart-2[data-rendered]").wait_for()
        systems = {page.get_attribute(f"#{i}", "data-system"): f"#{i}" for i in ("compare-chart", "compare-chart-2")}
        assert set(systems) == {"single", "large"}  # one chart per system
        single = mean_traces(page, systems["single"])
        large = mean_traces(page, systems["large"])
        # learning_rate is MG-RAO's own: the two jobs' uniform runs are one configuration of one world, and a
        # configuration keeps its name on every system (its suffix says what tells it from single's other one)
        assert {t["config"] for t in large} == {"large · uniform", "large · mgrao-max (learning_rate=0.1)"}
        assert {t["config"] for t in single} == {
            "single · uniform", "single · mgrao-max (learning_rate=0.1)", "single · mgrao-max (learning_rate=0.09)"}
        # every configuration of a chart its own colour; the first job's in its job page's order
        assert len({t["color"] for t in single}) == 3 and len({t["color"] for t in large}) == 2
        colour = {t["config"]: t["color"] for t in single + large}
        assert colour["large · uniform"] == colour["single · uniform"]
        assert colour["large · mgrao-max (learning_rate=0.1)"] == colour["single · mgrao-max (learning_rate=0.1)"]
        diff = page.locator("#param-diff")
        rows = diff.locator("tbody tr th").all_inner_texts()
        assert rows[0] == "system" and {"learning_rate", "n_parents"} <= set(rows)  # large differs in size too
        assert "0.09" in diff.inner_text()
        note = page.inner_text("#smoothing-note")
        assert "centred mean over 11 episodes" in note
        # the band's interval is in the mean line's hover
        hover = page.eval_on_selector("#compare-chart", "el => el.data.find(t => t.meta.kind === 'mean').hovertemplate")
        assert "95% CI" in hover
        page.screenshot(path=str(screenshots / "compare-facets.png"), full_page=True)

        # log scale and a y range apply to every chart of the view
        charts = list(systems.values())
        page.locator("input.log-y").check()
        page.wait_for_function("(ids) => ids.every(id => document.querySelector(id).layout.yaxis.type === 'log')",
                               arg=charts)
        page.fill("input.y-low", "0.5")
        page.fill("input.y-high", "20")
        page.locator("input.y-high").dispatch_event("change")
        page.wait_for_function("""(ids) => ids.every(id => { const r = document.querySelector(id).layout.yaxis.range;
            return r && Math.abs(r[0] - Math.log10(0.5)) < 1e-9 && Math.abs(r[1] - Math.log10(20)) < 1e-9; })""",
                               arg=charts)
        # zooming one chart's episodes zooms the other's
        page.evaluate("(id) => Plotly.relayout(document.querySelector(id), {'xaxis.range': [10, 30]})", charts[0])
        page.wait_for_function("(id) => { const r = document.querySelector(id).layout.xaxis.range; "
                               "return r && r[0] === 10 && r[1] === 30; }", arg=charts[1])
        # each chart saves as SVG; each table as CSV
        assert page.eval_on_selector(charts[0], "el => el._context.toImageButtonOptions.format") == "svg"
        with page.expect_download() as download_info:
            page.locator('button[data-csv="compare-final-utility.csv"]').click()
        lines = Path(download_info.value.path()).read_text().splitlines()
        # numbers, units in the column names (issue 29, point 4: not "+17.6%" nor "[5.354, 6.130]")
        assert lines[0] == ("system,configuration,job_ids,n_runs,n_paired,final_mean_utility,final_ci95_low_utility,"
                            "final_ci95_high_utility,pct_from_uniform_percent,pct_ci95_low_percent,"
                            "pct_ci95_high_percent,pct_of_max_percent") and len(lines) == 6
        for line in lines[1:]:
            cells = line.split(",")
            assert "%" not in line and "[" not in line
            assert all(math.isfinite(float(c)) for c in cells[5:8]), line
