"""The small things a new researcher trips over (issue: "the dashboard as a researcher reads it", 8):
a preset change keeps the parameters they changed, the valid group counts beside the x field,
letters in a number field, compare with nothing to show, header counts right after an action, and
the summary columns defined where they are shown."""

from __future__ import annotations

from playwright.sync_api import expect

from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_dashboard import api
from tests.frontend.test_job_view import post_job, wait_for


def health(base: str) -> dict:
    return api(base, "GET", "/health")


def active(reading: dict) -> int:
    return reading["running"] + reading["queued"]


def test_preset_change_keeps_edits_and_the_x_field_lists_valid_counts(page, server, screenshots):
    page.goto("/#/new")
    page.locator("form.newjob").wait_for()
    page.locator("details.advanced > summary").click()
    page.fill("input[name=learning_rate]", "0.05")
    page.fill("input[name=n_parents]", "12")
    help_text = page.locator(".argument-check").first  # MG-RAO's x:1 form (mgrao-adaptive's comes after it)
    expect(help_text).to_contain_text("Valid x here: 1, 2, 3, 4, 6, 12.")  # the registry for 12 parents
    page.fill("input.argument-values[data-template='mgrao-{x}:1']", "5, 4")
    expect(help_text).to_contain_text("mgrao-5:1 is not valid here")
    expect(help_text).to_contain_text("(valid: 1, 2, 3, 4, 6, 12)")
    assert "mgrao-4:1 is not valid" not in help_text.inner_text()  # 4 divides 12 (the memory line may name it)
    page.select_option("select[name=system]", "multi")
    kept = page.locator(".kept-edits")
    assert "learning_rate 0.05" in kept.inner_text() and "n_parents 12" in kept.inner_text()
    assert page.input_value("input[name=learning_rate]") == "0.05"
    page.screenshot(path=str(screenshots / "new-kept-edits.png"), full_page=True)
    kept.get_by_role("button", name="Use the preset’s values").click()
    assert page.input_value("input[name=learning_rate]") == "0.1"
    assert kept.inner_text() == ""
    # letters in a number field: the range at once, not an empty value sent to the server
    page.fill("input[name=seeds]", "")
    page.locator("input[name=seeds]").press_sequentially("1e")  # Chromium takes only digits and 'e' here
    error = page.locator('.field[data-for="seeds"] .field-error')
    assert "Not a number: must be a whole number from 1 to" in error.inner_text()


def test_compare_says_what_is_wrong_and_what_is_hidden(page, server):
    page.goto("/#/compare?jobs=abc")
    assert "“abc” is not a job id" in page.locator(".notice.error").inner_text()
    job = post_job(server, {"system": "single", "seeds": 2, "episodes": 20, "name": "hidden groups"})
    wait_succeeded(server, [job])
    page.goto(f"/#/compare?jobs={job['id']}&groups=none")
    page.locator("#compare-chart[data-rendered]").wait_for()
    assert "No configuration is ticked" in page.inner_text("#none-shown")
    assert "% of max: this configuration’s gain" in page.inner_text(".definitions")
    page.get_by_role("button", name="All").click()
    page.wait_for_function("() => !document.querySelector('#none-shown').textContent")


def test_header_counts_follow_an_action_at_once(page, server):
    # nothing left active by earlier tests, whose ending would offset the new job in the header's sum
    wait_for(lambda: active(health(server)) == 0, 120, "an idle queue")
    page.goto("/#/runs")
    page.locator("#health.ok").wait_for()
    before = page.inner_text("#health")
    queued_before = int(before.split("·")[2].split()[0])
    # the page's timers stopped, its 10 s poll of the header among them (their ids count up from 1): the
    # header can follow now only through the action itself, however long a loaded machine takes
    page.evaluate("() => { const last = setTimeout(() => {}, 0); "
                  "for (let id = 1; id <= last; id++) clearInterval(id); }")
    # submitted through the dashboard's own client: the header refreshes after the answer
    page.evaluate("""() => import('/js/api.js').then(({ api }) => api.createJob(
        { system: 'large', seeds: 1, episodes: 3000, params: { n_parents: 1000 }, name: 'header counts' }))""")
    page.wait_for_function(
        """(before) => { const t = document.getElementById('health').textContent;
            const [, running, queued] = t.split('·').map((x) => parseInt(x, 10));
            return running + queued > before; }""", arg=queued_before + int(before.split("·")[1].split()[0]),
        timeout=60000)
    listed = page.evaluate("() => import('/js/api.js').then(({ api }) => api.listJobs({ q: 'header counts' }))")
    job_id = listed["data"][0]["id"]
    page.evaluate(f"() => import('/js/api.js').then(({{ api }}) => api.cancelJob({job_id}))")


def test_keyboard_shortcuts(page, server, screenshots):
    jobs = [post_job(server, {"system": "single", "seeds": 2, "episodes": 10, "name": f"keys {i}", "tags": ["keys"]})
            for i in range(2)]
    wait_succeeded(server, jobs)
    page.goto("/#/compare")
    page.locator("h1").wait_for()
    page.keyboard.press("/")  # from elsewhere: the runs search
    page.wait_for_function("() => document.activeElement && document.activeElement.name === 'q'")
    page.keyboard.type("keys")
    page.locator(f'tr[data-id="{jobs[0]["id"]}"]').wait_for()
    page.locator("body").click(position={"x": 5, "y": 300})
    page.keyboard.press("c")  # nothing selected: said, not done, visibly and announced
    status = page.locator("#shortcut-status")
    assert "Select jobs" in status.text_content()
    assert status.get_attribute("aria-live") == "polite"
    status.wait_for(state="visible", timeout=5000)
    box = status.bounding_box()
    assert box and box["width"] > 100 and box["height"] > 10, f"the message is not readable on screen: {box}"
    page.screenshot(path=str(screenshots / "shortcut-nothing-selected.png"))
    for job in jobs:
        page.get_by_label(f"Select job {job['id']} for comparison").check()
    page.locator("h1").click()
    page.keyboard.press("c")
    page.wait_for_url(f"**/#/compare?jobs={jobs[0]['id']},{jobs[1]['id']}*")
    page.keyboard.press("?")
    dialog = page.locator("#shortcuts-dialog")
    dialog.wait_for()
    assert "Open a new experiment" in dialog.inner_text()
    page.screenshot(path=str(screenshots / "shortcuts.png"))
    page.keyboard.press("Escape")
    dialog.wait_for(state="detached")
    page.keyboard.press("n")
    page.wait_for_url("**/#/new")
