"""Round 2 of the dashboard as a newcomer reads it: the work budget on the new-experiment form (11),
what a queued job really waits for (4), and no console errors for a job with nothing stored yet or
a refused submit (5)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.frontend.conftest import page_at, running_service
from tests.frontend.test_dashboard import api
from tests.frontend.test_job_view import get_job, post_job, wait_for

pytestmark = [pytest.mark.browser, pytest.mark.slow]


def console_errors(page) -> list[str]:
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    return errors


def test_the_work_budget_fills_in_and_marks_what_drives_it(browser, server, screenshots):
    limits = api(server, "GET", "/systems")["limits"]
    assert limits["work_factors"] == ["seeds", "algorithms", "episodes", "n_parents", "types_per_composite"]
    with page_at(browser, server) as page:
        errors = console_errors(page)
        posts: list[str] = []
        page.on("request", lambda r: posts.append(r.url) if r.method == "POST" else None)
        page.goto("/#/new")
        page.get_by_label("System preset").select_option("single")
        budget = page.locator(".budget")
        limit = f"{limits['max_work']:,}"
        page.get_by_label("Seeds (number of runs)").fill("3")
        page.get_by_label("Episodes per run").fill("100")
        page.wait_for_function("() => document.querySelector('.budget-text').textContent.includes('3 seeds')")
        assert f"of {limit} allowed" in budget.inner_text()
        assert page.locator(".over-budget").count() == 0

        page.get_by_label("Seeds (number of runs)").fill("1000")
        page.get_by_label("Episodes per run").fill("100000")
        page.wait_for_function("() => document.querySelector('.budget').classList.contains('over')")
        assert f"over the limit of {limit} per experiment" in budget.inner_text()
        marked = page.locator(".over-budget").evaluate_all(
            "els => els.map(e => e.dataset.for || e.querySelector('[data-field]')?.dataset.field)")
        assert set(marked) == {"seeds", "episodes", "algorithms", "params.n_parents", "params.types_per_composite"}

        page.get_by_role("button", name="Run experiment").click()
        summary = page.locator(".error-summary:not(.own-system > .error-summary)")  # the form's own
        summary.get_by_text("see the marked fields").wait_for(timeout=10000)
        # the server's check (each field's own rule first, then the limit on their product) refuses it on `work`
        assert f"exceeds the limit of {limit} atomic tasks" in page.locator(".budget .field-error").inner_text()
        assert page.locator('input[name=seeds][aria-invalid="true"]').count() == 1
        assert page.locator('input[name=episodes][aria-invalid="true"]').count() == 1
        assert page.locator("fieldset.algos.invalid").count() == 1
        page.screenshot(path=str(screenshots / "new-experiment-over-budget.png"), full_page=True)
        assert not [u for u in posts if u.endswith("/api/jobs")], "an experiment over the limit was sent"

        # Within the budget but over the second bound (atomic tasks x parent groups): the server's
        # check refuses it on `work`; the same fields are marked, and no 422 reaches the console.
        page.get_by_label("System preset").select_option("large")
        for box in page.locator("fieldset.algos input[type=checkbox]").all():
            box.set_checked(box.get_attribute("value") == "mgrao-max")
        page.locator("input.argument-values[data-template='mgrao-{x}:1']").fill("")
        page.get_by_label("Seeds (number of runs)").fill("1000")
        page.get_by_label("Episodes per run").fill("3500")
        page.wait_for_function("() => !document.querySelector('.budget').classList.contains('over')")
        page.get_by_role("button", name="Run experiment").click()
        summary.get_by_text("The server rejected the experiment; see the marked fields.").wait_for(timeout=10000)
        assert "parent groups" in page.locator(".budget .field-error").inner_text()
        assert page.locator('input[name=episodes][aria-invalid="true"]').count() == 1
        page.screenshot(path=str(screenshots / "new-experiment-refused-by-check.png"), full_page=True)
        assert not [u for u in posts if u.endswith("/api/jobs")], "a refused experiment was submitted"
        assert any(u.endswith("/api/jobs/check") for u in posts)
        assert errors == [], errors


# About a minute of work for one worker: it stays running while the queued jobs are looked at.
SLOW = {"system": "large", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 6, "episodes": 15000,
        "params": {"n_parents": 1000}}


@pytest.fixture
def one_worker(tmp_path: Path) -> Iterator[str]:
    """A service of its own with one worker: the queue ahead of a job is known exactly."""
    with running_service(tmp_path, workers=1) as base:
        yield base


def waiting_text(page, job_id: int, pattern: str) -> str:
    page.goto(f"/#/jobs/{job_id}")
    page.wait_for_function("re => new RegExp(re).test(document.getElementById('job-waiting')?.textContent || '')",
                           arg=pattern, timeout=30000)
    return page.inner_text("#job-waiting")


def test_a_queued_job_says_what_it_really_waits_for_and_nothing_stored_is_no_error(browser, one_worker, screenshots):
    running = post_job(one_worker, {**SLOW, "name": "the running one"})
    wait_for(lambda: get_job(one_worker, running["id"])["status"] == "running", 120, "the slow job to start")
    nxt = post_job(one_worker, {"system": "single", "seeds": 2, "episodes": 20, "name": "next in the queue"})
    behind = post_job(one_worker, {"system": "single", "seeds": 2, "episodes": 20, "name": "behind it"})
    try:
        with page_at(browser, one_worker) as page:
            errors = console_errors(page)
            # Opened before its first chunk is stored: a state, said in the view, not a 409 in the console.
            page.goto(f"/#/jobs/{running['id']}")
            page.locator("#no-runs-yet").wait_for(timeout=30000)
            assert "No seed is complete yet" in page.inner_text("#no-runs-yet")
            page.locator("#no-runs-yet").scroll_into_view_if_needed()
            page.screenshot(path=str(screenshots / "job-nothing-stored-yet.png"))

            text = waiting_text(page, nxt["id"], "Next in the queue")
            assert "the ready worker is busy (1 job running)" in text and "queued before" not in text, text
            page.screenshot(path=str(screenshots / "job-next-in-queue.png"))
            text = waiting_text(page, behind["id"], "Waiting in the queue")
            assert "1 job was queued before this one" in text, text
            page.screenshot(path=str(screenshots / "job-behind-in-queue.png"))
            assert errors == [], errors
    finally:
        for job in (running, nxt, behind):
            if get_job(one_worker, job["id"])["status"] in ("queued", "running"):
                api(one_worker, "POST", f"/jobs/{job['id']}/cancel")
