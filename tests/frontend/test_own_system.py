"""Issue 20's plumbing in the dashboard: save your own system and run it; the list and event-list inputs.

The editor's test adds the look-alikes of tests/support/extra_params.py to GET /api/systems' schema in
the browser and reads what the form sends, so that it checks the inputs themselves whatever list
parameters the engine has (``composite_periods`` and ``schedule`` today).
"""

from __future__ import annotations

import json

from playwright.sync_api import expect

from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_dashboard import api
from tests.support.extra_params import EXAMPLE_PERIODS, EXAMPLE_SCHEDULE


def test_save_a_system_run_it_and_see_the_job(page, server, screenshots):
    page.goto("/#/new")
    page.locator("form.newjob").wait_for()
    page.locator("details.advanced > summary").click()
    page.fill("input[name=n_parents]", "12")
    page.fill("input[name=learning_rate]", "0.2")
    page.fill("input[name=saved-name]", "rush-hour")
    page.fill("input[name=saved-description]", "single with 12 parents learning faster")
    page.get_by_role("button", name="Save as a system").click()
    expect(page.locator(".own-system")).to_contain_text("Saved “rush-hour”: single with 2 changed values")
    expect(page.locator("select[name=system]")).to_have_value("rush-hour")
    expect(page.locator("form.newjob")).to_contain_text("single with 12 parents learning faster")
    assert page.input_value("input[name=n_parents]") == "12"
    exported = page.locator("a.export-system")
    expect(exported).to_be_visible()
    saved = api(server, "GET", "/systems/saved/rush-hour")
    assert saved["params"] == {"n_parents": 12, "learning_rate": 0.2}
    # a second visit lists it among the systems, with its description
    page.goto("/#/new")
    page.locator("form.newjob").wait_for()
    # among the saved systems (others of the shared server's tests may be there too), once
    expect(page.locator("select[name=system] optgroup[label='Saved systems'] option")
           .filter(has_text="rush-hour")).to_have_text(["rush-hour (single)"])
    page.select_option("select[name=system]", "rush-hour")
    page.fill("input[name=seeds]", "2")
    page.fill("input[name=episodes]", "10")
    page.screenshot(path=str(screenshots / "new-own-system.png"), full_page=True)
    page.get_by_role("button", name="Run experiment").click()
    page.wait_for_url("**/#/jobs/*")
    job_id = int(page.url.rsplit("/", 1)[1])
    job = api(server, "GET", f"/jobs/{job_id}")
    assert job["system"] == "single" and "system:rush-hour" in job["tags"] and job["params"]["n_parents"] == 12
    wait_succeeded(server, [job])
    expect(page.locator("body")).to_contain_text("system:rush-hour")
    page.screenshot(path=str(screenshots / "job-of-own-system.png"), full_page=True)


def test_the_list_and_event_list_inputs_send_json_values(page, server, screenshots):
    def with_examples(route):
        schema = route.fetch().json()
        schema["parameters"] += [EXAMPLE_PERIODS.as_dict(), EXAMPLE_SCHEDULE.as_dict()]
        for system in schema["systems"]:
            system["params"] |= {"example_periods": [], "example_schedule": []}
        route.fulfill(json=schema)

    sent = []

    def check(route):
        sent.append(json.loads(route.request.post_data))
        route.fulfill(json={"valid": False, "detail": [
            {"loc": ["body", "params", "example_schedule", 1, "fraction"], "field": "example_schedule[1].fraction",
             "msg": "example_schedule[1].fraction: must be in [0, 1] (got 1.5)", "type": "value_error"}]})

    page.route("**/api/systems", with_examples)
    page.route("**/api/jobs/check", check)
    page.goto("/#/new")
    page.locator("form.newjob").wait_for()
    page.locator("details.advanced > summary").click()
    page.fill("input[name=example_periods]", "1, 2, 4")
    editor = page.locator(".event-list[data-param=example_schedule]")
    editor.get_by_role("button", name="Add an event").click()
    editor.get_by_role("button", name="Add an event").click()
    editor.get_by_role("button", name="Add an event").click()
    rows = editor.locator("tbody tr")
    expect(rows).to_have_count(3)
    rows.nth(0).locator("input[name='example_schedule.episode']").fill("50")
    rows.nth(0).locator("select[name='example_schedule.change']").select_option("frequencies")
    rows.nth(1).locator("input[name='example_schedule.episode']").fill("70")
    rows.nth(1).locator("input[name='example_schedule.fraction']").fill("1.5")
    editor.get_by_role("button", name="Remove example_schedule 3").click()
    expect(rows).to_have_count(2)
    page.get_by_role("button", name="Run experiment").click()
    expect(page.locator('.field[data-for="params.example_schedule"] .field-error')).to_contain_text(
        "example_schedule[1].fraction: must be in [0, 1] (got 1.5)")
    page.screenshot(path=str(screenshots / "new-event-list.png"), full_page=True)
    params = sent[0]["params"]
    assert params["example_periods"] == [1, 2, 4]
    assert params["example_schedule"] == [{"episode": 50, "change": "frequencies", "fraction": 0.3},
                                          {"episode": 70, "change": "new-profiles", "fraction": 1.5}]
