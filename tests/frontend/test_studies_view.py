"""Browser tests of the studies: the new-study form, the study view filling in, a trial opening its job."""

from __future__ import annotations

import re
import time

import pytest
from playwright.sync_api import expect
from test_dashboard import api, assert_local

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def wait_study(base: str, study_id: int, timeout: float = 180.0) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        answer = api(base, "GET", f"/studies/{study_id}")
        if answer["study"]["status"] != "running":
            return answer
        time.sleep(0.3)
    raise AssertionError(f"study {study_id} still running after {timeout} s")


def sweep(page, name: str, values: str) -> None:
    """Tick the parameter's sweep box and give it values."""
    page.locator(f'input[data-sweep="{name}"]').check()
    block = page.locator(f'.field[data-for="params.{name}"]')
    block.get_by_label(f"{name}: range or values").select_option("values")
    block.get_by_label(f"{name} values").fill(values)


def test_a_three_by_three_grid_from_the_form_fills_its_heatmap_and_opens_a_job(page, server, screenshots):
    page.goto("/#/studies/new")
    expect(page.get_by_role("heading", name="New study")).to_be_visible()
    page.get_by_label("Seeds per trial").fill("2")
    page.get_by_label("Episodes per run").fill("20")
    page.get_by_label("Name").fill("browser 3x3")
    page.locator('input[data-sweep="learning_rate"]').check()
    rate = page.locator('.field[data-for="params.learning_rate"]')
    assert rate.get_by_label("learning_rate from").input_value() == "0.05"  # prefilled: half to twice 0.1
    assert rate.get_by_label("learning_rate to").input_value() == "0.2"
    assert rate.get_by_label("learning_rate steps").input_value() == "3"
    sweep(page, "trace_decay", "0.5, 0.7, 0.9")
    expect(page.locator(".grid-size")).to_have_text(re.compile(r"Grid: 3 × 3 = 9 trials"))
    page.get_by_label("Trials in flight").fill("3")
    page.screenshot(path=str(screenshots / "study-new.png"), full_page=True)
    page.get_by_role("button", name="Start study").click()

    page.wait_for_url(re.compile(r"#/studies/\d+$"))
    study_id = int(page.url.rsplit("/", 1)[1])
    expect(page.get_by_role("heading", name="browser 3x3")).to_be_visible()
    # the heatmap fills in as the trials finish (the view polls the study's revision)
    page.wait_for_function("() => document.querySelector('.study-heatmap')?.dataset.cells === '9'", timeout=180_000)
    done = wait_study(server, study_id)
    assert done["study"]["trials"] == {"succeeded": 9}
    expect(page.locator(".study-state")).to_contain_text("9/9", timeout=30_000)  # the next poll, at the latest
    heat = page.evaluate("() => document.querySelector('.study-heatmap').data[0].z")
    assert len(heat) == 3 and all(len(row) == 3 and all(v is not None for v in row) for row in heat)
    expect(page.locator(".study-slice")).to_have_count(2, timeout=30_000)  # drawn after the heatmap
    expect(page.locator("table.trials tbody tr")).to_have_count(9, timeout=30_000)
    page.screenshot(path=str(screenshots / "study-view.png"), full_page=True)

    # sort by the objective, best first: the first row is the study's best trial
    page.get_by_role("button", name=re.compile("pct_from_uniform of mgrao-max")).click()
    best = done["study"]["best_trial"]
    first = page.locator("table.trials tbody tr").first
    assert first.get_attribute("data-number") == str(best)
    job_id = next(t["job_ids"][0] for t in done["trials"] if t["number"] == best)
    first.locator("td").nth(2).click()  # a row opens its job
    page.wait_for_url(re.compile(rf"#/jobs/{job_id}$"))
    expect(page.get_by_role("link", name=f"Its study ({study_id})")).to_be_visible()
    assert_local(page, server)


def test_bad_sweeps_are_marked_beside_their_field(page, server):
    page.goto("/#/studies/new")
    page.locator('input[data-sweep="learning_rate"]').check()
    rate = page.locator('.field[data-for="params.learning_rate"]')
    rate.get_by_label("learning_rate from").fill("0.5")
    rate.get_by_label("learning_rate to").fill("0.1")
    page.get_by_role("button", name="Start study").click()
    error = rate.locator(".sweep .field-error")
    expect(error).to_contain_text("low must be below high")
    expect(page.locator(".error-summary")).to_contain_text("The server rejected the study")
    assert page.url.endswith("#/studies/new")


def test_the_new_experiment_form_hands_its_experiment_to_a_new_study(page, server):
    page.goto("/#/new")
    page.get_by_label("System preset").select_option("multi")
    page.get_by_label("Seeds (number of runs)").fill("7")
    page.get_by_role("link", name="Sweep parameters: new study").click()
    page.wait_for_url(re.compile(r"#/studies/new"))
    expect(page.get_by_label("System preset")).to_have_value("multi")
    expect(page.get_by_label("Seeds per trial")).to_have_value("7")


def test_a_study_over_a_preset_and_a_saved_system_from_the_form(page, server, screenshots):
    api(server, "POST", "/systems/saved", {"name": "study-twelve", "description": "single with 12 parents",
                                           "base": "single", "params": {"n_parents": 12}})
    try:  # the server is shared: other tests list the saved systems
        study_over_a_preset_and_a_saved_system(page, server, screenshots)
    finally:
        api(server, "DELETE", "/systems/saved/study-twelve")


def study_over_a_preset_and_a_saved_system(page, server, screenshots):
    page.goto("/#/studies/new")
    expect(page.get_by_role("heading", name="New study")).to_be_visible()
    page.get_by_label("Seeds per trial").fill("1")
    page.get_by_label("Episodes per run").fill("10")
    page.get_by_label("Name", exact=True).fill("preset and saved")
    sweep(page, "learning_rate", "0.05, 0.2")
    page.get_by_label("study-twelve (saved, single)").check()  # beside the presets' boxes
    page.screenshot(path=str(screenshots / "study-new-saved-system.png"), full_page=True)
    page.get_by_role("button", name="Start study").click()
    page.wait_for_url(re.compile(r"#/studies/\d+$"))
    study_id = int(page.url.rsplit("/", 1)[1])
    done = wait_study(server, study_id)
    assert done["study"]["trials"] == {"succeeded": 2}
    systems = done["definition"]["base"]["system"]  # the saved one inlined when the study was made
    assert systems[0] == "single" and systems[1] == {"name": "study-twelve", "system": "single",
                                                     "params": {"n_parents": 12}}, systems
    jobs = [api(server, "GET", f"/jobs/{j}") for t in done["trials"] for j in t["job_ids"]]
    twelve = [j for j in jobs if "system:study-twelve" in j["tags"]]
    assert len(jobs) == 4 and len(twelve) == 2 and all(j["params"]["n_parents"] == 12 for j in twelve)


def test_the_studies_list_shows_progress_and_links(page, server):
    study = api(server, "POST", "/studies", {
        "name": "listed", "method": "random", "max_trials": 2, "max_in_flight": 2,
        "base": {"system": "single", "seeds": 1, "episodes": 5},
        "space": {"learning_rate": {"low": 0.01, "high": 0.5, "log": True}},
        "objective": {"configuration": "mgrao-max", "metric": "final_mean"}})
    study_id = study["study"]["id"]
    wait_study(server, study_id)
    page.goto("/#/studies")
    row = page.locator(f'tr[data-id="{study_id}"]')
    expect(row).to_contain_text("2/2")
    expect(row).to_contain_text("maximize final_mean of mgrao-max")
    row.get_by_role("link", name="listed").click()
    page.wait_for_url(re.compile(rf"#/studies/{study_id}$"))
    expect(page.get_by_role("heading", name="listed")).to_be_visible()


def test_a_study_run_until_decided_names_the_trials_that_stopped_at_max_seeds(page, server, screenshots):
    """A study whose base has a stopping rule: the rule in the study's summary, and the trials whose rule reached
    max_seeds unanswered marked, with a note saying their objective is less precise than asked."""
    created = api(server, "POST", "/studies", {
        "name": "until max", "base": {"system": "single", "episodes": 20, "until": {"half_width": 0.01,
                                                                                    "max_seeds": 20}},
        "space": {"learning_rate": {"values": [0.05, 0.2]}},
        "objective": {"metric": "pct_from_uniform", "direction": "maximize", "configuration": "mgrao-max"}})
    study_id = created["study"]["id"]
    done = wait_study(server, study_id)
    assert all(t["max_seeds_jobs"] for t in done["trials"])
    page.goto(f"/#/studies/{study_id}")
    note = page.locator("#max-seeds-trials")
    note.wait_for(timeout=60_000)
    assert note.inner_text().startswith("2 trials stopped at max_seeds before the stopping rule answered")
    assert page.locator("table.trials .max-seeds").count() == 2
    meta = page.locator(".meta").inner_text()
    assert "Seeds run in blocks of 10 until the 95% interval of" in meta and "at most 20 seeds" in meta
    assert_local(page, server)
    page.screenshot(path=str(screenshots / "study-until-max-seeds.png"), full_page=True)
