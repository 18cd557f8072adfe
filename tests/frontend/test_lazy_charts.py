"""The compare view draws the charts on screen first: a chart below the fold is drawn when it scrolls
near, or once the page is idle after its first paint, and each chart, whenever drawn, shows exactly the
compare answer's data (issue 18, point 14: the cached reload's time went to drawing charts nobody saw yet).
"""

from __future__ import annotations

import time

import pytest

from tests.frontend.conftest import page_at
from tests.frontend.test_dashboard import api, wait_job
from tests.frontend.test_job_view import post_job

pytestmark = [pytest.mark.browser, pytest.mark.slow]

CHARTS = ("#compare-chart", "#compare-bars")
NEVER_IDLE = "window.requestIdleCallback = () => 0;"  # this page is never idle: only scrolling draws


@pytest.fixture(scope="module")
def compared(server) -> list[int]:
    base = {"system": "single", "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"], "seeds": 3, "episodes": 40,
            "tags": ["lazy-charts"]}
    jobs = [post_job(server, base | {"name": "lazy a"}), post_job(server, base | {"name": "lazy b", "seeds": [5, 6]})]
    for job in jobs:  # a generous deadline: the workers may still be compiling their kernel on a busy machine
        assert wait_job(server, job["id"], timeout=600)["status"] == "succeeded"
    return [j["id"] for j in jobs]


def drawn(page, selector: str) -> bool:
    return page.evaluate("sel => { const el = document.querySelector(sel); return !!(el && el.dataset.rendered "
                         "&& el.data && el.querySelector('.main-svg')); }", selector)


def wait_drawn(page, selectors, seconds: float, why: str) -> None:
    """Wait until every chart of `selectors` is drawn; the failure names the charts still blank."""
    deadline = time.monotonic() + seconds
    while True:
        blank = [s for s in selectors if not drawn(page, s)]
        if not blank:
            return
        assert time.monotonic() < deadline, f"after {seconds:.0f} s {why}, still not drawn: {', '.join(blank)}"
        page.wait_for_timeout(100)


def below_fold(page, selector: str) -> float:
    return page.eval_on_selector(selector, "el => el.getBoundingClientRect().top - window.innerHeight")


def test_a_chart_below_the_fold_is_drawn_when_scrolled_to(browser, server, screenshots, compared):
    with page_at(browser, server, 1280, 700) as page:
        page.add_init_script(NEVER_IDLE)
        page.goto(f"/#/compare?jobs={','.join(map(str, compared))}")
        wait_drawn(page, ["#compare-chart"], 60, "loading the compare view (the chart on screen)")
        assert page.get_attribute("#compare-chart", "data-drawn") == "now"
        assert below_fold(page, "#compare-bars") > 100, "the bars are not below the fold at 1280x700"
        page.wait_for_timeout(1500)  # nothing on screen asks for the bars
        assert not drawn(page, "#compare-bars"), "the bars below the fold were drawn before anyone scrolled to them"
        assert page.get_attribute("main", "data-all-drawn-ms") is None
        page.locator("#compare-bars").scroll_into_view_if_needed()
        wait_drawn(page, ["#compare-bars"], 30, "scrolling the bars into view")
        assert page.get_attribute("#compare-bars", "data-drawn") == "seen"
        page.locator("main[data-all-drawn-ms]").wait_for()
        page.screenshot(path=str(screenshots / "compare-bars-drawn-on-scroll.png"))


def test_every_chart_is_drawn_without_scrolling_and_shows_the_answer(browser, server, screenshots, compared):
    ids = ",".join(map(str, compared))
    with page_at(browser, server, 1280, 700) as page:
        page.goto(f"/#/compare?jobs={ids}")
        wait_drawn(page, CHARTS, 60, "loading the compare view without scrolling (the page idle after its first paint)")
        assert page.get_attribute("#compare-chart", "data-drawn") == "now"
        assert page.get_attribute("#compare-bars", "data-drawn") == "idle"
        assert page.evaluate("performance.getEntriesByName('compare-rendered').length") == 1
        assert page.evaluate("performance.getEntriesByName('compare-all-drawn').length") == 1
        assert page.evaluate("window.scrollY") == 0
        page.screenshot(path=str(screenshots / "compare-all-drawn-idle.png"), full_page=True)

        # what each chart shows is the answer's data, whenever it was drawn
        answer = api(server, "GET", f"/compare?jobs={ids}&points=500")
        groups = {g["algorithm"]: g for g in answer["groups"]}
        lines = page.eval_on_selector("#compare-chart", """el => el.data.filter(t => t.meta.kind === 'mean')
            .map(t => ({config: t.meta.config, x: Array.from(t.x), y: Array.from(t.y)}))""")
        assert len(lines) == len(groups) == 3
        for line in lines:
            group = groups[line["config"].split(" · ")[-1]]
            assert line["x"] == group["episodes"]["episode"]
            assert line["y"] == pytest.approx(group["episodes"]["mean"], rel=1e-12, abs=1e-12)
        bands = page.eval_on_selector("#compare-chart", "el => el.data.filter(t => t.meta.kind === 'band').length")
        assert bands == 3
        bars = page.eval_on_selector("#compare-bars",
                                     "el => ({x: Array.from(el.data[0].x), y: Array.from(el.data[0].y)})")
        expected = {g["algorithm"]: g["summary"]["pct_from_uniform"] for g in answer["groups"]}
        shown = {label.split(" · ")[-1]: y for label, y in zip(bars["x"], bars["y"], strict=True)}
        assert shown == pytest.approx(expected)


def test_a_redraw_before_the_bars_are_drawn_draws_them_once_with_the_latest_view(browser, server, compared):
    """Hiding a configuration while the bars still wait: when scrolled to, they show the view as it is."""
    with page_at(browser, server, 1280, 700) as page:
        page.add_init_script(NEVER_IDLE)
        page.goto(f"/#/compare?jobs={','.join(map(str, compared))}")
        wait_drawn(page, ["#compare-chart"], 60, "loading the compare view (the chart on screen)")
        page.get_by_label("single · uniform").uncheck()
        page.wait_for_function("() => document.querySelector('#compare-chart').data"
                               ".filter(t => t.meta.kind === 'mean').length === 2")
        assert not drawn(page, "#compare-bars")
        page.locator("#compare-bars").scroll_into_view_if_needed()
        wait_drawn(page, ["#compare-bars"], 30, "scrolling the bars into view after a configuration was hidden")
        labels = page.eval_on_selector("#compare-bars", "el => Array.from(el.data[0].x)")
        assert len(labels) == 2 and not any(label.endswith("uniform") for label in labels)
