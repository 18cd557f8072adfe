"""The charts and the runs table as a newcomer reads them at 1280x800: bands that let the mean lines
show through (with a toggle kept in the URL and a caution when they are too wide to mean much), one
colour per configuration shown together and the same one from view to view, compare's legend below
its axis title, study plots whose titles clear their tick labels, and a runs table with optional
columns that fits the screen.

Real `mgrao serve` with real workers (the session's), headless Chromium; each test makes its own jobs.
"""

from __future__ import annotations

import re
import time
import urllib.parse
from pathlib import Path

import pytest

from tests.frontend.conftest import page_at, settled_boxes
from tests.frontend.test_dashboard import api
from tests.frontend.test_job_view import get_job, post_job

pytestmark = pytest.mark.browser

FIVE = ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-10:1", "mgrao-max"]


def palette() -> list[str]:
    """The dashboard's palette (frontend/js/colours.js), whose slots the registry's colour keys name."""
    source = (Path(__file__).resolve().parents[2] / "frontend" / "js" / "colours.js").read_text()
    return re.findall(r"'(#[0-9A-F]{6})'", re.search(r"PALETTE = \[(.*?)\]", source).group(1))


def registry_colours(server: str, labels: list[str]) -> dict[str, str]:
    """Each label's colour by its registry colour key (GET /api/algorithms?label=...)."""
    query = "&".join(f"label={urllib.parse.quote(label)}" for label in labels)
    described = api(server, "GET", f"/algorithms?{query}")["data"]
    return {d["label"]: palette()[d["colour_key"]] for d in described}


def wait_succeeded(server: str, jobs: list[dict], timeout: float = 180) -> None:
    deadline = time.monotonic() + timeout
    while any(get_job(server, j["id"])["status"] != "succeeded" for j in jobs):
        assert time.monotonic() < deadline, f"jobs {[j['id'] for j in jobs]} did not succeed within {timeout} s"
        time.sleep(0.3)


def traces(page, selector: str, kind: str) -> list[dict]:
    return page.eval_on_selector(selector, """(el, kind) => el.data.filter(t => t.meta && t.meta.kind === kind)
        .map(t => ({config: t.meta.config, color: t.line.color, dash: t.line.dash, fill: t.fillcolor || null}))""",
                                 kind)


def test_runs_table_with_result_and_parameter_columns_fits_1280(browser, server, screenshots):
    body = {"system": "single", "algorithms": ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max"], "seeds": 2,
            "episodes": 20, "tags": ["fit-columns", "a-longer-tag"],
            "name": "learning rate against trace decay, single system"}
    jobs = [post_job(server, body | {"params": {"learning_rate": rate, "trace_decay": 0.85}}) for rate in (0.05, 0.2)]
    wait_succeeded(server, jobs)
    with page_at(browser, server) as page:
        page.goto("/#/runs?tag=fit-columns&result=mgrao-max&cols=learning_rate,trace_decay")
        page.locator('td[data-column="param.trace_decay"]').nth(1).wait_for()
        page.wait_for_function("() => !document.querySelector('[aria-busy=true]')")
        wrap = page.locator(".table-wrap").first
        sizes = wrap.evaluate("el => [el.scrollWidth, el.clientWidth]")
        page.screenshot(path=str(screenshots / "runs-columns-1280.png"))
        assert sizes[0] <= sizes[1], f"the runs table is {sizes[0]} px wide in a {sizes[1]} px box at 1280x800"
        name = page.locator(f'tr[data-id="{jobs[0]["id"]}"] td.job-name a')
        lines = name.evaluate("el => Math.round(el.getBoundingClientRect().height"
                              " / parseFloat(getComputedStyle(el).lineHeight))")
        assert lines <= 3, f"the job's name wraps to {lines} lines"


def box(page, selector: str) -> dict:
    found = page.locator(selector).first.bounding_box()
    assert found is not None, f"{selector} is not drawn"
    return found


def test_job_bands_let_the_lines_show_and_each_configuration_has_its_own_colour(browser, server, screenshots):
    """Three seeds: the bands are slabs around every line. They are drawn light and under the lines,
    a caution says they mean little, a toggle (kept in the URL) hides them; each configuration is
    drawn in its registry colour (GET /api/algorithms' colour_key, when free: here all are); a compare
    of the job draws it in the same colours."""
    job = post_job(server, {"system": "single", "algorithms": FIVE, "seeds": 3, "episodes": 60, "name": "three seeds"})
    wait_succeeded(server, [job])
    with page_at(browser, server) as page:
        page.goto(f"/#/jobs/{job['id']}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        kinds = page.eval_on_selector("#utility-chart", "el => el.data.map(t => t.meta.kind)")
        assert kinds == ["band"] * 5 + ["mean"] * 5  # every band under every line
        bands = traces(page, "#utility-chart", "band")
        assert all(b["fill"].endswith(", 0.07)") for b in bands), bands
        means = traces(page, "#utility-chart", "mean")
        colour = {t["config"]: t["color"] for t in means}
        assert len(set(colour.values())) == 5, colour
        assert colour == registry_colours(server, FIVE), colour  # each its registry colour: the same in any job
        # round 2's complaint: 1:1 and 10:1 both blue, 5:1 and max both orange; the palette's two blues
        # and two oranges are now never given to these five together
        hue = {"#0072B2": "blue", "#56B4E9": "blue", "#D55E00": "orange", "#E69F00": "orange"}
        assert len({hue.get(c.upper(), c) for c in colour.values()}) == 5, colour
        caution = page.inner_text("#band-caution")
        assert "too wide to mean much" in caution and "3 seeds per configuration (fewer than 10)" in caution
        page.locator("#utility-chart").scroll_into_view_if_needed()
        page.screenshot(path=str(screenshots / "job-bands-3-seeds.png"), full_page=True)
        page.get_by_label("95% bands").uncheck()
        page.wait_for_function("() => !document.querySelector('#utility-chart').data.some(t => t.meta.kind === 'band')")
        assert "bands=0" in page.url
        assert page.inner_text("#band-caution") == ""
        assert "95% bands hidden" in page.inner_text("#smoothing-note")
        page.reload()  # the URL keeps it
        page.locator("#utility-chart[data-rendered]").wait_for()
        assert not page.get_by_label("95% bands").is_checked()
        assert traces(page, "#utility-chart", "band") == []
        page.screenshot(path=str(screenshots / "job-no-bands.png"), full_page=True)

        page.goto(f"/#/compare?jobs={job['id']}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        compared = {t["config"].split(" · ")[1]: t["color"] for t in traces(page, "#compare-chart", "mean")}
        assert compared == colour  # the same configuration, the same colour


def test_compare_with_many_groups_keeps_its_plot_legend_and_titles_apart(browser, server, screenshots):
    """Four jobs, 11 groups on one system and 3 on another: the plot area keeps 300 px, the legend
    sits below the "Episode" title, each system's title lies inside its figure, every group of a chart
    has its own line style, and the pooled table's jobs are #id links."""
    base = {"seeds": 2, "episodes": 30, "tags": ["many-groups"]}
    jobs = [post_job(server, base | {"system": "single", "algorithms": FIVE})]
    four = ["uniform", "mgrao-1:1", "mgrao-5:1", "mgrao-max"]
    jobs += [post_job(server, base | {"system": "single", "algorithms": four,
                                      "params": {"learning_rate": rate, "trace_decay": 0.85}}) for rate in (0.05, 0.2)]
    jobs.append(post_job(server, base | {"system": "large", "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"]}))
    wait_succeeded(server, jobs)
    with page_at(browser, server) as page:
        page.goto(f"/#/compare?jobs={','.join(str(j['id']) for j in jobs)}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        page.locator("#compare-chart-2[data-rendered]").wait_for()
        for chart in ("#compare-chart", "#compare-chart-2"):
            parts = [chart, f"{chart} .nsewdrag", f"{chart} .gtitle", f"{chart} .xtitle", f"{chart} .legend"]
            figure, plot, title, axis_title, legend = settled_boxes(page, parts, f"{chart}'s layout").values()
            assert plot["height"] >= 280, f"{chart}: the plot area is squeezed to {plot['height']} px"
            assert title["y"] >= figure["y"] and title["y"] + title["height"] <= plot["y"], f"{chart}: title {title}"
            assert legend["y"] >= axis_title["y"] + axis_title["height"], f"{chart}: legend {legend} over {axis_title}"
            assert legend["y"] + legend["height"] <= figure["y"] + figure["height"] + 1, f"{chart}: legend outside"
            styles = page.eval_on_selector(chart, """el => el.data.filter(t => t.meta.kind === 'mean')
                .map(t => [t.line.color, t.line.dash, t.marker ? t.marker.symbol : null].join('|'))""")
            assert len(set(styles)) == len(styles), f"{chart}: configurations share a line style: {styles}"
        first_is_single = page.get_attribute("#compare-chart", "data-system") == "single"
        single = traces(page, "#compare-chart" if first_is_single else "#compare-chart-2", "mean")
        # uniform of the three single jobs is one configuration (learning_rate and trace_decay are MG-RAO's own):
        # 11 groups, eight colours, then dashes
        assert len(single) == 11 and len({t["color"] for t in single}) == 8
        page.locator("#compare-bars[data-rendered]").wait_for()  # below the fold: drawn once the page is idle
        bars = settled_boxes(page, ["#compare-bars .nsewdrag"], "the bars' layout")["#compare-bars .nsewdrag"]
        assert bars["height"] >= 240, f"the % from uniform bars are squeezed to {bars['height']} px by their labels"
        links = page.locator("table.summary td.job-links a")
        assert links.first.inner_text().startswith("#")
        assert links.first.get_attribute("href").startswith("#/jobs/")
        page.locator("#compare-chart-2").scroll_into_view_if_needed()
        page.screenshot(path=str(screenshots / "compare-many-groups.png"), full_page=True)


def test_study_heatmap_titles_clear_their_ticks_and_parallel_axes_label_between_ends(browser, server, screenshots):
    study = api(server, "POST", "/studies", {
        "name": "heatmap titles", "method": "grid", "max_trials": 9, "max_in_flight": 2,
        "base": {"system": "single", "seeds": 1, "episodes": 5},
        "space": {"learning_rate": {"low": 0.01, "high": 0.1, "steps": 3, "log": True},
                  "trace_decay": {"values": [0.8, 0.85, 0.9]}},
        "objective": {"configuration": "mgrao-max", "metric": "final_mean"}})
    study_id = study["study"]["id"]
    deadline = time.monotonic() + 240
    while api(server, "GET", f"/studies/{study_id}")["study"]["status"] == "running":
        assert time.monotonic() < deadline, f"study {study_id} still running after 240 s"
        time.sleep(0.5)
    with page_at(browser, server) as page:
        page.goto(f"/#/studies/{study_id}?x=trace_decay&y=learning_rate")  # the longer tick labels on y
        page.wait_for_function("() => document.querySelector('.study-heatmap')?.dataset.cells === '9'")
        heat = ".study-heatmap"
        settled_boxes(page, [heat, f"{heat} .ytitle", f"{heat} .xtitle", f"{heat} .nsewdrag"], "the heatmap's layout")
        ytitle = box(page, f"{heat} .ytitle")
        yticks = page.locator(f"{heat} .yaxislayer-above .ytick text").evaluate_all(
            "els => els.map(e => e.getBoundingClientRect()).map(r => ({x: r.x, width: r.width}))")
        assert yticks, "the heatmap has no y tick labels"
        assert ytitle["x"] + ytitle["width"] <= min(t["x"] for t in yticks), f"y title {ytitle} overlaps {yticks}"
        xtitle = box(page, f"{heat} .xtitle")
        xticks = page.locator(f"{heat} .xaxislayer-above .xtick text").evaluate_all(
            "els => els.map(e => e.getBoundingClientRect()).map(r => r.y + r.height)")
        assert xtitle["y"] >= max(xticks), "the heatmap's x title overlaps its tick labels"
        labels = page.eval_on_selector(".study-parallel", """el => el.layout.annotations
            .filter(a => a.x === 0 && !a.text.startsWith('<b>')).map(a => a.text)""")
        assert len(labels) == 5, labels  # both ends and three values between
        page.locator(".study-heatmap").scroll_into_view_if_needed()
        page.screenshot(path=str(screenshots / "study-heatmap-parallel.png"), full_page=True)


def rgb(hex_colour: str) -> str:
    n = int(hex_colour.lstrip("#"), 16)
    return f"rgb({n >> 16 & 255}, {n >> 8 & 255}, {n & 255})"


def test_the_paper_view_gives_each_configuration_its_job_page_colour(browser, server, screenshots):
    job = post_job(server, {"system": "single", "seeds": 3, "episodes": 100, "tags": ["paper"],
                            "name": "paper colours"})
    wait_succeeded(server, [job])
    with page_at(browser, server) as page:
        page.goto("/#/paper")
        rows = page.locator('#paper-table tbody tr[data-system="single"]')
        rows.first.wait_for()
        shown = rows.first.locator("a").inner_text().lstrip("#")  # the newest single paper run: this or a later one
        background = "e => getComputedStyle(e).backgroundColor"
        dots = {r.get_attribute("data-algorithm"): r.locator(".dot").evaluate(background) for r in rows.all()}
        page.screenshot(path=str(screenshots / "paper-colours.png"), full_page=True)
        page.goto(f"/#/jobs/{shown}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        colour = {t["config"]: rgb(t["color"]) for t in traces(page, "#utility-chart", "mean")}
        assert dots and all(dots[a] == colour[a] for a in dots), (dots, colour)
        assert len(set(dots.values())) == len(dots)
