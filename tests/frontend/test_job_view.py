"""The job view as a researcher reads it: the configuration against its preset, curves that fill in
while the job runs, and a job whose worker was killed saying so (attempts and the re-queue reason).

Real `mgrao serve` with real workers, real SQLite files, headless Chromium; the killed worker is
SIGKILLed by process id.
"""

from __future__ import annotations

import json
import os
import re
import signal
import sqlite3
import urllib.request
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.frontend.conftest import page_at, running_service
from tests.support.waiting import wait_until


def post_job(base: str, body: dict) -> dict:
    request = urllib.request.Request(f"{base}/api/jobs", data=json.dumps(body).encode(), method="POST",
                                     headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=30) as response:
        return json.loads(response.read())


def get_job(base: str, job_id: int) -> dict:
    with urllib.request.urlopen(f"{base}/api/jobs/{job_id}", timeout=30) as response:
        return json.loads(response.read())


def wait_for(predicate, timeout: float, what: str, step: float = 0.2):
    return wait_until(predicate, timeout, what, step=step)


def test_job_shows_its_configuration_against_the_preset(page, server, screenshots):
    job = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3, "episodes": 30,
                            "params": {"learning_rate": 0.05, "quality_model": "exponential"}, "name": "config view"})
    page.goto(f"/#/jobs/{job['id']}")
    summary = page.locator("#config-summary")
    summary.wait_for()
    assert "2 of" in summary.inner_text() and "learning_rate 0.05" in summary.inner_text()
    assert "quality_model exponential" in summary.inner_text()
    differs = page.locator("tr.differs")
    assert sorted(differs.evaluate_all("rows => rows.map(r => r.dataset.param)")) == ["learning_rate", "quality_model"]
    assert "preset 0.1" in page.locator("tr[data-param=learning_rate]").inner_text()
    assert page.locator("tr[data-param=trace_decay]:not(.differs)").count() == 1  # the rest is listed, plain
    page.locator("#utility-chart .main-svg").first.wait_for(timeout=60000)
    page.locator("#config-details").scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "job-config.png"), full_page=True)

    with page.expect_download() as download_info:
        page.click("#download-summary")
    lines = Path(download_info.value.path()).read_text().splitlines()
    head = lines[0].split(",")
    assert len(lines) == 3 and "learning_rate" in head and "quality_model" in head
    first = dict(zip(head, lines[1].split(","), strict=True))
    assert first["algorithm"] == "uniform" and first["learning_rate"] == "0.05"
    assert first["quality_model"] == "exponential" and first["seeds_stored"] == "3"
    with page.expect_download() as download_info:
        page.click("#download-config")
    config = json.loads(Path(download_info.value.path()).read_text())
    assert config["params"]["learning_rate"] == 0.05 and config["system"] == "single"


@pytest.fixture
def restless_server(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    """`mgrao serve` with one worker and a 4 s staleness: a killed worker's job is re-queued soon."""
    with running_service(tmp_path, workers=1, MGRAO_STALE_AFTER_S="4", MGRAO_HEARTBEAT_S="0.5",
                         MGRAO_PROGRESS_S="0.5") as base:
        yield base, tmp_path / "t.db"


def worker_pid(database: Path, job_id: int) -> int | None:
    with sqlite3.connect(database, timeout=10) as connection:
        row = connection.execute("SELECT worker_id FROM jobs WHERE id = ? AND status = 'running'", (job_id,)).fetchone()
    return int(row[0].rsplit(":", 1)[1]) if row and row[0] else None


def stored_runs(database: Path, job_id: int) -> int:
    with sqlite3.connect(database, timeout=10) as connection:
        return connection.execute("SELECT count(*) FROM runs WHERE job_id = ?", (job_id,)).fetchone()[0]


def test_curves_fill_in_and_a_requeued_job_says_why(browser, restless_server, screenshots):
    base, database = restless_server
    # one seed per chunk (30M atomic tasks a seed; a chunk holds at most 50M), a few seconds each: twelve of
    # them, so the job still runs when its worker is killed, however slow the machine
    job = post_job(base, {"system": "large", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 12, "episodes": 3000,
                          "params": {"n_parents": 1000}, "name": "live curves"})
    with page_at(browser, base) as page:
        page.goto(f"/#/jobs/{job['id']}")
        note = page.locator("#partial-note")
        note.wait_for(timeout=120000)  # the first chunk stored: its curves are drawn while the job runs
        assert "filling in" in note.inner_text()
        assert re.search(r"uniform ([1-9]|1[0-2]) of 12", note.inner_text())  # the chunks stored so far
        page.locator("#utility-chart .main-svg").first.wait_for()
        assert get_job(base, job["id"])["status"] == "running"
        page.screenshot(path=str(screenshots / "job-live.png"), full_page=True)

        pid = wait_for(lambda: worker_pid(database, job["id"]), 30, "the job's worker")
        kept = stored_runs(database, job["id"])
        os.kill(pid, signal.SIGKILL)
        requeue = page.locator("#requeue-note")
        requeue.wait_for(timeout=120000)
        assert "was killed by SIGKILL" in requeue.inner_text()  # serve's supervisor handed it back at once
        wait_for(lambda: get_job(base, job["id"])["status"] == "succeeded", 300, "the job to succeed", step=1)
        page.locator("#partial-note").wait_for(state="detached", timeout=30000)
        page.locator("#utility-chart .main-svg").first.wait_for()
        final = get_job(base, job["id"])
        assert final["attempts"] == 2 and "was killed by SIGKILL" in final["requeue_reason"]
        assert "Attempt 2" in page.locator("#requeue-note").inner_text()
        page.screenshot(path=str(screenshots / "job-requeued.png"), full_page=True)
        # every run stored exactly once; what the killed attempt stored was kept, not recomputed
        assert stored_runs(database, job["id"]) == 24 and kept >= 2


def test_a_drift_jobs_utility_chart_marks_its_scheduled_event(page, server, screenshots):
    plain = post_job(server, {"system": "drift", "seeds": 2, "episodes": 100, "name": "drift preset"})
    page.goto(f"/#/jobs/{plain['id']}")  # the preset's own event: 30% new profiles at episode 50
    chart = page.locator("#utility-chart")
    chart.locator(".main-svg").first.wait_for(timeout=60000)
    wait_for(lambda: chart.locator(".shapelayer path").count() == 1, 30, "the preset's event line")
    assert chart.evaluate("gd => gd.layout.shapes.map(s => s.x0)") == [50]
    assert chart.locator(".annotation-text").evaluate_all("els => els.map(e => e.textContent)") == ["new-profiles 30%"]

    # drift: 30% of the parents draw new value profiles at episode 50; an event past the run's end is not drawn
    schedule = [{"episode": 50, "change": "new-profiles", "fraction": 0.3},
                {"episode": 20, "change": "frequencies", "fraction": 0.5, "period": 2},
                {"episode": 500, "change": "new-profiles"}]
    job = post_job(server, {"system": "drift", "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"], "seeds": 3,
                            "episodes": 100, "params": {"schedule": schedule}, "name": "drift marks"})
    page.goto(f"/#/jobs/{job['id']}")
    chart = page.locator("#utility-chart")
    chart.locator(".main-svg").first.wait_for(timeout=60000)
    wait_for(lambda: get_job(server, job["id"])["status"] == "succeeded", 120, "the drift job to succeed")
    lines = chart.locator(".shapelayer path")
    labels = chart.locator(".annotation-text")
    wait_for(lambda: lines.count() == 2 and labels.count() == 2, 30, "a dashed line per fired event")
    texts = sorted(labels.evaluate_all("els => els.map(e => e.textContent)"))  # SVG text: no innerText
    assert texts == ["frequencies → 2 50%", "new-profiles 30%"], texts
    shapes = chart.evaluate("gd => gd.layout.shapes.map(s => [s.x0, s.line.dash])")
    assert sorted(shapes) == [[20, "dash"], [50, "dash"]]
    # the configuration lists the schedule one event per line across the card, the preset's beside it
    row = page.locator("tr.list-param[data-param=schedule]")
    assert row.locator("li").all_inner_texts() == [
        "episode 50: new-profiles, fraction 0.3, period 1", "episode 20: frequencies, fraction 0.5, period 2",
        "episode 500: new-profiles, fraction 1, period 1"]
    assert "preset: episode 50: new-profiles, fraction 0.3, period 1" in row.inner_text()
    heights = row.locator("li").evaluate_all("els => els.map(e => e.getBoundingClientRect().height)")
    assert max(heights) < 2 * min(heights) + 1, f"one event per line, not a wrapped character column: {heights}"
    chart.scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "job-drift-events.png"), full_page=True)


def test_a_job_run_until_decided_shows_why_it_stopped_and_its_intervals_narrowing(page, server, screenshots):
    """A job with a stopping rule: the rule in words, the reason it stopped, the judged intervals, and their chart
    with one point per block (issue "seeds until decided")."""
    job = post_job(server, {"system": "single", "episodes": 40, "first_seed": 300, "name": "until decided",
                            "until": {"half_width": 2.5, "block": 10, "max_seeds": 200}})
    done = wait_for(lambda: (lambda j: j if j["status"] == "succeeded" else None)(get_job(server, job["id"])), 120,
                    "the job to stop")
    stopped = done["stopped"]
    assert stopped["reason"] in ("half_width", "max_seeds") and len(stopped["blocks"]) == stopped["seeds"] // 10
    page.goto(f"/#/jobs/{job['id']}")
    reason = page.locator("#rule-reason")
    reason.wait_for()
    words = {"half_width": f"Stopped after {stopped['seeds']} seeds: every judged interval is within ±2.5",
             "max_seeds": f"Stopped at max_seeds, {stopped['seeds']} seeds"}[stopped["reason"]]
    assert words in reason.inner_text()
    rule = page.locator("#stopping-rule").inner_text()
    assert "blocks of 10" in rule and "for mgrao-1:1, mgrao-max (each covering its own value 95% of the time" in rule
    rows = page.locator("#rule-intervals tbody tr")
    assert rows.count() == 2  # mgrao-1:1 and mgrao-max; uniform is the baseline, not judged
    page.locator("#rule-chart .main-svg").first.wait_for(timeout=60000)
    points = page.evaluate("() => document.getElementById('rule-chart').data.filter(t => t.mode === 'lines+markers')"
                           ".map(t => t.x.length)")
    assert points == [len(stopped["blocks"])] * 2
    widths = page.evaluate("() => document.getElementById('rule-chart').data.filter(t => t.fill === 'toself')"
                           ".map(t => { const n = t.x.length / 2; return [t.y[0] - t.y[2 * n - 1], "
                           "t.y[n - 1] - t.y[n]]; })")
    assert all(last < first for first, last in widths)  # the intervals narrowed from the first block to the last
    page.locator("#stopping-rule").scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "job-stopping-rule.png"), full_page=True)


def test_the_new_experiment_form_runs_seeds_until_decided(page, server, screenshots):
    """The form's stopping rule: a bad half width refused beside its field, then a rule that runs, its job view."""
    page.goto("/#/new")
    page.locator("form.newjob").wait_for()
    page.get_by_label("System preset").select_option("single")
    page.get_by_label("Episodes per run").fill("30")
    page.locator("#until-on").check()
    assert page.locator("input[name=seeds]").is_disabled()  # the rule runs as many seeds as it needs
    page.fill("#until-max-seeds", "120")
    page.wait_for_function("() => document.querySelector('.budget-text').textContent.startsWith('Work: 120 seeds')")
    page.fill("#until-half-width", "0")
    page.get_by_role("button", name="Run experiment").click()
    error = page.locator('.field[data-for="until.half_width"] .field-error')
    error.wait_for(timeout=10000)
    page.wait_for_function("(el) => el.textContent.includes('must be more than 0')", arg=error.element_handle())
    page.fill("#until-half-width", "3")
    page.fill("#until-max-seeds", "40")
    page.fill("#until-first-seed", "200")
    assert "every algorithm but uniform and oracle" in page.get_attribute("#until-judge", "placeholder")
    page.fill("#until-judge", "oracle")  # not run by this job: refused beside its field
    page.get_by_role("button", name="Run experiment").click()
    judge_error = page.locator('.field[data-for="until.judge"] .field-error')
    judge_error.wait_for(timeout=10000)
    page.wait_for_function("(el) => el.textContent.includes('oracle: not run')", arg=judge_error.element_handle())
    page.fill("#until-judge", "mgrao-max, mgrao-01:1")
    page.locator("#until-joint").check()
    page.get_by_role("button", name="Run experiment").click()
    page.wait_for_url(re.compile(r"#/jobs/\d+$"))
    job_id = int(page.url.rsplit("/", 1)[1])
    done = wait_for(lambda: (lambda j: j if j["status"] == "succeeded" else None)(get_job(server, job_id)), 120,
                    "the job to stop")
    assert done["until"] == {"half_width": 3.0, "of": "pct_from_uniform", "max_seeds": 40, "block": 10, "decide": None,
                             "judge": ["mgrao-max", "mgrao-1:1"], "joint": True}
    assert done["seeds"][0] == 200 and done["stopped"]["reason"] in ("half_width", "max_seeds")
    page.wait_for_function(  # the view polls the running job, and says why once it stopped (a new element)
        "n => { const el = document.getElementById('rule-reason'); "
        "return !!el && el.textContent.startsWith('Stopped') && el.textContent.includes(`${n} seeds`); }",
        arg=done["stopped"]["seeds"], timeout=30000)
    assert "jointly: each at 97.5%, so that all 2 hold at once" in page.locator("#stopping-rule").inner_text()
    page.locator("#clone-job").click()  # a clone keeps the rule
    page.locator("#until-on:checked").wait_for(timeout=10000)
    assert page.input_value("#until-half-width") == "3" and page.input_value("#until-first-seed") == "200"
    assert page.input_value("#until-judge") == "mgrao-max, mgrao-1:1" and page.is_checked("#until-joint")
    page.screenshot(path=str(screenshots / "new-experiment-until.png"), full_page=True)


def test_a_job_whose_tasks_fail_shows_each_configurations_failed_and_handed_over_share(page, server, screenshots):
    """Tasks that fail and a hierarchy that hands them over: the job view draws each configuration's failure and
    hand-over rates (its summary's, pooled over its seeds) beside a table of them, and compare's pooled table lists
    them; a job whose tasks cannot fail shows neither."""
    body = {"system": "multi", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 2, "episodes": 20,
            "params": {"task_need": 1.5, "hierarchy": "hand-over"}, "name": "tasks that fail"}
    job = post_job(server, body)
    plain = post_job(server, body | {"params": {}, "name": "no task fails"})

    def succeeded(job_id: int) -> dict | None:
        current = get_job(server, job_id)
        assert current["status"] not in ("failed", "cancelled"), current["error"]
        return current if current["status"] == "succeeded" else None

    # the first job of failing tasks compiles the engine's hierarchy once in the service's worker
    summaries = wait_for(lambda: succeeded(job["id"]), 600, f"job {job['id']} to succeed", step=0.5)["summaries"]
    rates = {a: [summaries[a]["failure_rate"], summaries[a]["handover_rate"]] for a in body["algorithms"]}
    assert all(0 < rate < 1 for pair in rates.values() for rate in pair), rates

    page.goto(f"/#/jobs/{job['id']}")
    chart = page.locator("#task-rates-chart")
    chart.locator(".main-svg").first.wait_for(timeout=60000)
    assert "Atomic tasks that failed / a neighbour completed" in page.locator("#h-tasks").inner_text()
    drawn = chart.evaluate("gd => Object.fromEntries(gd.data.map(t => [t.meta.config, [t.x, t.y]]))")
    for algorithm, (failure, handover) in rates.items():
        assert drawn[algorithm][0] == ["Failed", "By a neighbour"]
        assert drawn[algorithm][1] == pytest.approx([100 * failure, 100 * handover])
        cells = page.locator(f"#task-rates-table tr[data-config='{algorithm}'] td")
        shown = [float(text.rstrip("%")) for text in cells.all_inner_texts()]
        assert shown == [pytest.approx(100 * failure, abs=0.051), pytest.approx(100 * handover, abs=0.051)]
    page.locator("#task-rates").scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "job-view-failures.png"), full_page=True)
    page.locator("#task-rates").screenshot(path=str(screenshots / "job-view-failures-section.png"))

    wait_for(lambda: succeeded(plain["id"]), 120, f"job {plain['id']} (no task fails) to succeed", step=0.5)
    page.goto(f"/#/jobs/{plain['id']}")
    page.locator("#utility-chart .main-svg").first.wait_for(timeout=60000)
    assert page.locator("#task-rates").count() == 0  # nothing can fail: nothing said

    page.goto(f"/#/compare?jobs={job['id']}")
    table = page.locator("#pooled-table")
    table.wait_for()
    assert table.locator("thead th").all_inner_texts()[-2:] == ["Failed", "By a neighbour"]
    for algorithm, pair in rates.items():
        row = table.locator("tbody tr").filter(has_text=algorithm).first
        shown = [float(text.rstrip("%")) for text in row.locator("td[data-rate]").all_inner_texts()]
        assert shown == [pytest.approx(100 * rate, abs=0.051) for rate in pair]
