"""Clone a job into the new-experiment form with its whole configuration; tag, cancel and delete
several jobs at once from the runs table."""

from __future__ import annotations

import json
import urllib.request

from playwright.sync_api import expect

from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_job_view import get_job, post_job


def test_clone_a_job_into_the_form(page, server, screenshots):
    source = post_job(server, {"system": "multi", "algorithms": ["uniform", "mgrao-max"], "seeds": [3, 7],
                               "episodes": 30, "params": {"learning_rate": 0.07, "routing": "per-task"},
                               "name": "to clone", "tags": ["clone"]})
    wait_succeeded(server, [source])
    page.goto(f"/#/jobs/{source['id']}")
    page.locator("#clone-job").click()
    page.wait_for_url(f"**/#/new?clone={source['id']}")
    page.locator("#clone-note").wait_for()
    assert "seeds (3, 7)" in page.inner_text("#clone-note")
    assert page.input_value("select[name=system]") == "multi"
    assert page.input_value("input[name=learning_rate]") == "0.07"
    assert page.input_value("select[name=routing]") == "per-task"
    assert page.input_value("input[name=name]") == "to clone (clone)"
    page.screenshot(path=str(screenshots / "clone.png"), full_page=True)
    page.get_by_role("button", name="Run experiment").click()
    page.wait_for_url("**/#/jobs/*")
    clone = get_job(server, int(page.url.rsplit("/", 1)[1]))
    original = get_job(server, source["id"])
    for key in ("system", "algorithms", "seeds", "episodes", "params", "config_hash"):
        assert clone[key] == original[key], key


def test_bulk_tag_cancel_and_delete(page, server, screenshots):
    done = [post_job(server, {"system": "single", "seeds": 1, "episodes": 5, "name": f"bulk {i}", "tags": ["bulk"]})
            for i in range(2)]
    wait_succeeded(server, done)
    # about a minute of work, so it is still queued or running when cancelled however slow the machine
    slow = post_job(server, {"system": "large", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 30, "episodes": 3000,
                             "params": {"n_parents": 1000}, "name": "bulk slow", "tags": ["bulk"]})
    page.goto("/#/runs?tag=bulk")
    for job in [*done, slow]:
        page.get_by_label(f"Select job {job['id']} for comparison").check()
    page.get_by_role("button", name="Tag selected").click()
    # comma separated like every other tag field: two tags, not one "reviewed, quicklook"
    page.get_by_label("Tags to add to 3 jobs").fill("reviewed, quicklook")
    page.get_by_role("dialog").get_by_role("button", name="Add tags").click()
    page.wait_for_function("() => document.getElementById('bulk-status').textContent.startsWith('Tagged: 3 of 3')")
    for job in [*done, slow]:
        assert get_job(server, job["id"])["tags"] == ["bulk", "reviewed", "quicklook"]
    expect(page.locator(f'tr[data-id="{slow["id"]}"] button.tag')).to_have_text(["bulk", "reviewed", "quicklook"])

    page.get_by_role("button", name="Cancel selected").click()
    page.get_by_role("dialog").get_by_role("button", name="Cancel them").click()
    page.wait_for_function("() => document.getElementById('bulk-status').textContent.startsWith('Cancelled: 1 of 3')")
    assert "2 skipped (not queued or running)" in page.inner_text("#bulk-status")
    assert get_job(server, slow["id"])["status"] == "cancelled"
    page.locator(f'tr[data-id="{slow["id"]}"][data-status="cancelled"]').wait_for()
    page.screenshot(path=str(screenshots / "runs-bulk.png"), full_page=True)

    page.get_by_role("button", name="Delete selected").click()
    page.get_by_role("dialog").get_by_role("button", name="Delete them").click()
    page.wait_for_function("() => document.getElementById('bulk-status').textContent.startsWith('Deleted: 3 of 3')")
    with urllib.request.urlopen(f"{server}/api/jobs?tag=bulk", timeout=30) as answer:
        assert json.loads(answer.read())["count"] == 0
    assert page.locator("table.runs tbody tr").count() == 0
