"""A newcomer's first ten minutes, round 3 (issue 30): what the forms say, in the product's words."""

from __future__ import annotations

from tests.frontend.conftest import page_at
from tests.frontend.test_newcomer_round2 import console_errors


def test_the_new_experiment_form_marks_every_refused_field_at_once_each_by_its_own_rule(browser, server, screenshots):
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto("/#/new")
        page.get_by_label("System preset").select_option("single")
        page.get_by_label("Seeds (number of runs)").fill("1e9")
        page.get_by_label("Episodes per run").fill("2.5")
        page.locator("details.advanced > summary").click()
        for name, value in (("learning_rate", "5"), ("n_types", "100000"), ("resource_mean", "-1")):
            page.locator(f"[data-field='params.{name}']").fill(value)
        page.get_by_role("button", name="Run experiment").click()
        summary = page.locator(".error-summary:not(.own-system > .error-summary)")
        summary.get_by_text("see the marked fields").wait_for(timeout=10000)
        text = " | ".join(page.locator(".field-error").all_inner_texts())  # each message beside its field
        # each field's own rule, every one at once; nothing "over the work limit" while a field is wrong
        for said in ("seeds: must be at most 1000", "episodes: must be a whole number (got 2.5)",
                     "learning_rate: must be in [0, 1] (got 5)", "n_types: must be in [2, 200] (got 100000)",
                     "resource_mean: must be in [0.001, 1] (got -1)"):
            assert said in text, text
        assert "work limit" not in text
        invalid = page.locator("[aria-invalid='true']").evaluate_all(
            "els => els.map(e => e.dataset.field || e.name)")
        assert {"seeds", "episodes", "params.learning_rate", "params.n_types", "params.resource_mean"} <= set(invalid)
        assert page.locator("fieldset.algos.invalid").count() == 0  # the configurations are fine
        assert "Input should" not in text and "List should" not in text  # no validation library's wording
        assert "work limit" not in summary.inner_text()
        page.screenshot(path=str(screenshots / "new-experiment-every-error.png"), full_page=True)
        assert errors == [], errors


def test_the_form_checks_a_saved_system_with_its_own_parameters(browser, server, screenshots):
    from tests.frontend.test_dashboard import api

    for body in ({"name": "walk-p30", "base": "large", "params": {"n_parents": 30}},
                 {"name": "two-res", "base": "single", "params": {"n_resources": 2}}):
        try:
            api(server, "POST", "/systems/saved", body)
        except Exception:  # noqa: BLE001 - saved by an earlier run of the session's server
            pass
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto("/#/new")
        system = page.get_by_label("System preset")
        system.select_option("walk-p30")
        check = page.locator("small.argument-check").first
        page.wait_for_function("(el) => el.textContent.includes('Valid x here: 1, 2, 3, 5, 6, 10, 15, 30.')",
                               arg=check.element_handle())
        page.locator("input.argument-values[data-template='mgrao-{x}:1']").fill("3, 15")
        page.wait_for_function("(el) => el.textContent.includes('mgrao-15:1') && !el.classList.contains('warn')",
                               arg=check.element_handle())
        assert "not" not in check.inner_text().split("Memory")[0]  # 3 and 15 are valid here
        page.screenshot(path=str(screenshots / "new-experiment-saved-system-checks.png"), full_page=True)
        # a change of the parent count in the form follows at once, on top of the saved system's
        page.locator("details.advanced > summary").click()
        page.locator("[data-field='params.n_parents']").fill("12")
        page.wait_for_function("(el) => el.textContent.includes('Valid x here: 1, 2, 3, 4, 6, 12.')",
                               arg=check.element_handle())
        # memory per child of a two-resource system: one row of weights per resource
        page.goto("/#/new")
        system.select_option("single")
        memory = "() => document.querySelector(\"small.memory[data-label='mgrao-max']\")?.textContent || ''"
        page.wait_for_function(f"() => ({memory})().includes('per child')")
        one = page.evaluate(memory)
        system.select_option("two-res")
        page.wait_for_function(f"(one) => ({memory})().includes('per child') && ({memory})() !== one", arg=one)
        assert page.evaluate(memory) != one, one
        assert errors == [], errors


def test_individual_seeds_of_a_large_job_are_drawn_at_the_points_that_fit(browser, server, screenshots):
    """Issue 30, point 4: 1,680 runs x 700 episodes do not fit one answer at 600 points a curve; the view asked
    for them anyway (422 "use points <= 593"), left the box ticked and drew nothing."""
    from tests.frontend.test_compare_view import wait_succeeded
    from tests.frontend.test_job_view import post_job

    job = post_job(server, {"system": "single", "algorithms": ["uniform", "oracle"], "seeds": 840, "episodes": 700,
                            "name": "many seeds"})
    wait_succeeded(server, [job])
    with page_at(browser, server) as page:
        errors = console_errors(page)
        asked: list[str] = []
        page.on("request", lambda r: asked.append(r.url) if "/results" in r.url else None)
        page.goto(f"/#/jobs/{job['id']}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        page.locator("#utility-chart").evaluate("el => { delete el.dataset.rendered; }")
        page.get_by_label("Show individual seeds").check()
        page.locator("#utility-chart[data-rendered]").wait_for(timeout=60000)
        seeds = page.eval_on_selector("#utility-chart", "el => el.data.filter(t => t.meta.kind === 'seed').length")
        assert seeds == 2 * 20  # every seed's curve read; a sample of 20 a configuration drawn (issue 43, item 9)
        points = [int(u.split("points=")[1].split("&")[0]) for u in asked if "include_seeds=true" in u]
        assert points == [593], asked  # 1,000,000 values / (2 x 3 + 1,680 curves)
        assert page.get_by_label("Show individual seeds").is_checked()
        assert page.inner_text("#seeds-note") == ""
        page.screenshot(path=str(screenshots / "job-many-seeds.png"), full_page=True)
        assert errors == [], errors


def test_a_new_study_error_of_no_field_is_brought_into_view_and_focused(browser, server, screenshots):
    with page_at(browser, server, height=700) as page:
        page.goto("/#/studies/new")
        start = page.get_by_role("button", name="Start study")
        start.scroll_into_view_if_needed()
        for sweep in page.locator("input.sweep:checked").all():  # nothing swept: the space is empty
            sweep.uncheck()
        start.click()
        alert = page.locator(".error-summary .notice.error").first
        alert.wait_for(timeout=10000)
        assert "the parameters swept" in alert.inner_text()  # the space, in the form's words (issue 43, item 5)
        assert page.evaluate("document.activeElement === document.querySelector('.error-summary .notice.error')")
        top, bottom = page.evaluate("(() => { const r = document.querySelector('.error-summary .notice.error')"
                                    ".getBoundingClientRect(); return [r.top, r.bottom]; })()")
        assert 0 <= top and bottom <= 700, (top, bottom)  # in view, not above the page's top
        page.screenshot(path=str(screenshots / "new-study-error-in-view.png"))


def test_the_runs_table_exports_offers_every_configuration_and_knows_saved_systems(browser, server, screenshots):
    import csv
    import io
    from pathlib import Path

    from tests.frontend.test_compare_view import wait_succeeded
    from tests.frontend.test_dashboard import api
    from tests.frontend.test_job_view import post_job

    try:
        api(server, "POST", "/systems/saved", {"name": "rush-7", "base": "single", "params": {"n_parents": 7}})
    except Exception:  # noqa: BLE001 - saved by an earlier run of the session's server
        pass
    saved = post_job(server, {"system": "rush-7", "algorithms": ["uniform", "mgrao-7:1"], "seeds": 2, "episodes": 10,
                              "name": "on my saved system", "tags": ["round3-runs"]})
    preset = post_job(server, {"system": "large", "algorithms": ["uniform", "mgrao-2:1"], "seeds": 2, "episodes": 10,
                               "name": "on large", "tags": ["round3-runs"]})
    wait_succeeded(server, [saved, preset])
    with page_at(browser, server, width=1400) as page:
        page.goto("/#/runs?tag=round3-runs")
        page.locator("table.runs tbody tr").nth(1).wait_for()
        cell = page.locator(f"table.runs tbody tr[data-id='{saved['id']}'] td.system")
        assert cell.inner_text() == "rush-7" and "based on single" in cell.get_attribute("title")
        options = page.locator("select[name=result] option").all_inner_texts()
        assert {"mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-25:1", "mgrao-7:1"} <= set(options), options
        page.locator("select[name=system]").select_option("rush-7")
        page.wait_for_function("() => document.querySelectorAll('table.runs tbody tr').length === 1")
        assert page.locator("table.runs tbody tr").get_attribute("data-id") == str(saved["id"])
        page.locator("select[name=system]").select_option("")
        page.locator("select[name=result]").select_option("mgrao-2:1")
        page.wait_for_function("() => document.querySelectorAll('table.runs tbody tr').length === 2")
        with page.expect_download() as download:
            page.locator("#export-csv").click()
        rows = list(csv.DictReader(io.StringIO(Path(download.value.path()).read_text())))
        assert {r["name"] for r in rows} == {"on my saved system", "on large"}
        large = next(r for r in rows if r["name"] == "on large")
        assert large["configuration"] == "mgrao-2:1" and float(large["pct_from_uniform_percent"]) == \
            api(server, "GET", f"/jobs/{preset['id']}")["summaries"]["mgrao-2:1"]["pct_from_uniform"]
        assert next(r for r in rows if r["name"] == "on my saved system")["saved_system"] == "rush-7"
        page.screenshot(path=str(screenshots / "runs-saved-system-and-export.png"), full_page=True)

        # the compare picker searches every succeeded job, not only the 20 newest
        page.goto("/#/compare")
        page.locator("#job-picker").wait_for()
        page.locator("input.pick-search").fill("on my saved")
        page.wait_for_function("() => [...document.querySelectorAll('#job-picker li')].length === 1")
        assert "rush-7" in page.inner_text("#job-picker li")


def test_small_things_a_reader_notices(browser, server, screenshots):
    """Issue 30, point 9: headings, word breaks, an event's label, the oracle's colour, the studies' docs link."""
    from tests.frontend.conftest import settled_boxes
    from tests.frontend.test_compare_view import wait_succeeded
    from tests.frontend.test_job_view import post_job

    # (mgrao-1:1 beside adaptive groups: a kernel the suite compiles anyway, tests/support/kernels.py)
    job = post_job(server, {"system": "drift", "algorithms": ["uniform", "mgrao-1:1", "mgrao-adaptive:2", "oracle"],
                            "seeds": 2, "episodes": 80, "name": "small things",
                            "params": {"frequency_profile": "explicit", "composite_periods": [1] * 10}})
    wait_succeeded(server, [job])
    with page_at(browser, server, width=1100) as page:
        page.goto(f"/#/jobs/{job['id']}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        colours = page.eval_on_selector("#utility-chart", """el => Object.fromEntries(el.data
            .filter(t => t.meta && t.meta.kind === 'mean').map(t => [t.name, t.line.color]))""")
        assert colours["oracle"] == "#56B4E9", colours  # sky blue, as in every job, beside adaptive groups
        boxes = settled_boxes(page, ["#utility-chart", "#utility-chart .annotation"], "the chart's event label")
        figure, label = boxes["#utility-chart"], boxes["#utility-chart .annotation"]
        assert label["y"] >= figure["y"], (label, figure)  # the event's label inside the figure, not clipped
        headings = page.locator(".config-table caption").all_inner_texts()
        assert headings and len(headings) == len(set(headings)), headings  # "System" once
        assert all(h[0].isupper() for h in headings), headings
        assert page.eval_on_selector(".config-table td", "el => getComputedStyle(el).overflowWrap") == "break-word"
        page.screenshot(path=str(screenshots / "job-small-things.png"), full_page=True)
        page.goto("/#/runs")
        page.locator("table.runs td.algos .label").first.wait_for()
        assert page.eval_on_selector("table.runs td.algos .label", "el => getComputedStyle(el).whiteSpace") == "nowrap"
        page.goto("/#/studies/new")
        link = page.get_by_role("link", name="How studies work")
        assert link.get_attribute("href") == "/project-docs/studies.html"
