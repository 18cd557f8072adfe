"""The standard learners in the dashboard (issue 21 point 3): ``independent-q`` and ``bandit`` come
from the registry into the new-experiment picker (with their memory per child), and a job with them
draws them in the job and compare views, each in its registry colour, between MG-RAO and the oracle.

Real `mgrao serve` with real workers (the session's), headless Chromium.
"""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.frontend.conftest import page_at
from tests.frontend.test_charts_read import registry_colours, traces, wait_succeeded
from tests.frontend.test_dashboard import api
from tests.frontend.test_job_view import post_job

pytestmark = pytest.mark.browser

LEARNERS = ["independent-q", "bandit"]
LABELS = ["uniform", "mgrao-1:1", "mgrao-max", *LEARNERS, "oracle"]


def test_the_learners_are_in_the_new_experiment_picker(browser, server, screenshots):
    single = {d["label"]: d for d in api(server, "GET", "/algorithms?system=single&" + "&".join(
        f"label={label}" for label in LEARNERS))["data"]}
    with page_at(browser, server) as page:
        page.goto("/#/new")
        page.locator("form.newjob").wait_for()
        page.get_by_label("System preset").select_option("single")
        for label in LEARNERS:
            box = page.locator(f"fieldset.algos input[type=checkbox][value={label}]")
            expect(box).to_have_count(1)
            expect(box).not_to_be_checked()  # not one of the paper's configurations
            memory = page.locator(f"fieldset.algos small.memory[data-label={label}]")
            expect(memory).to_contain_text("per child")
            assert str(single[label]["memory_per_child"]) in memory.inner_text().replace(",", "")
        page.locator("fieldset.algos").scroll_into_view_if_needed()
        page.screenshot(path=str(screenshots / "new-experiment-learners.png"), full_page=True)


def test_a_job_with_the_learners_draws_them_in_job_and_compare_views(browser, server, screenshots):
    job = post_job(server, {"system": "single", "algorithms": LABELS, "seeds": 2, "episodes": 20,
                            "name": "standard learners beside MG-RAO"})
    wait_succeeded(server, [job])
    expected = registry_colours(server, LABELS)
    assert len(set(expected.values())) == len(LABELS)  # every one in its own registry colour
    with page_at(browser, server) as page:
        page.goto(f"/#/jobs/{job['id']}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        means = traces(page, "#utility-chart", "mean")
        assert {t["config"]: t["color"] for t in means} == expected
        assert [t["config"] for t in means] == LABELS  # views order: uniform, MG-RAO, the learners, the oracle
        page.locator("#utility-chart").scroll_into_view_if_needed()
        page.screenshot(path=str(screenshots / "job-standard-learners.png"), full_page=True)

        page.goto(f"/#/compare?jobs={job['id']}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        page.locator("main[data-all-drawn-ms]").wait_for()  # every chart, those below the fold too
        compared = {t["config"].split(" · ")[-1]: t["color"] for t in traces(page, "#compare-chart", "mean")}
        assert compared == expected
        page.screenshot(path=str(screenshots / "compare-standard-learners.png"), full_page=True)
