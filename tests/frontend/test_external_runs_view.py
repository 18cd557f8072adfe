"""Runs logged from outside in the dashboard: marked in the runs table and the job view, and in compare
beside the built-in configurations of the same world, % from uniform paired seed by seed."""

from __future__ import annotations

import json
import urllib.request

import numpy as np
from playwright.sync_api import expect

from mgrao_client import Client
from tests.frontend.conftest import page_at
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_job_view import post_job


def uniform_runs(server: str, job_id: int) -> dict[int, list[float]]:
    with urllib.request.urlopen(f"{server}/api/jobs/{job_id}/episodes?format=json", timeout=30) as response:
        rows = json.loads(response.read())
    runs: dict[int, list[float]] = {}
    for row in rows:
        if row["algorithm"] == "uniform":
            runs.setdefault(row["seed"], []).append(row["utility"])
    return runs


def test_an_external_run_is_marked_and_compared_beside_built_in_runs_of_its_world(browser, server, screenshots):
    built_in = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3,
                                 "episodes": 40, "name": "built-in beside external"})
    wait_succeeded(server, [built_in])
    uniform = uniform_runs(server, built_in["id"])
    client = Client(server)
    with client.open_run(label="my-learner", system="single", seeds=3, episodes=40, name="my learner") as run:
        for seed, values in uniform.items():
            run.log(seed, (np.array(values) * 1.2).tolist())  # 20% above uniform, seed by seed
    left_open = client.open_run(label="half-done", system="single", seeds=2, episodes=40, name="left open")
    left_open.log(0, [1.0] * 40)
    left_open.flush()

    with page_at(browser, server) as page:
        page.goto("/#/runs")
        row = page.locator(f"tr[data-id='{run.id}']")
        expect(row.locator(".badge.kind-external")).to_have_text("external")
        expect(row.locator(".badge.status-succeeded")).to_be_visible()
        open_row = page.locator(f"tr[data-id='{left_open.id}']")
        expect(open_row.locator(".badge.status-open")).to_have_text("open")
        expect(open_row.locator(".badge.kind-external")).to_be_visible()
        expect(open_row.locator("progress")).to_have_attribute("value", "50")
        expect(page.locator(f"tr[data-id='{built_in['id']}'] .badge.kind-external")).to_have_count(0)
        page.screenshot(path=str(screenshots / "external-runs-table.png"), full_page=True)

        page.goto(f"/#/jobs/{run.id}")
        expect(page.locator(".job-status .badge.kind-external")).to_have_text("external")
        expect(page.locator("#clone-job")).to_have_count(0)
        page.locator("#utility-chart[data-rendered]").wait_for()
        page.screenshot(path=str(screenshots / "external-job-view.png"), full_page=True)

        page.goto(f"/#/compare?jobs={built_in['id']},{run.id}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        page.locator("main[data-all-drawn-ms]").wait_for()  # every chart, those below the fold too
        traces = page.eval_on_selector("#compare-chart", """el => el.data.filter(t => t.meta && t.meta.kind === 'mean')
            .map(t => ({config: t.meta.config, color: t.line.color}))""")
        configs = {t["config"]: t["color"] for t in traces}
        assert set(configs) == {"single · uniform", "single · mgrao-max", "single · my-learner · external"}
        assert len(set(configs.values())) == 3
        row = page.locator("#pooled-table tr").filter(has_text="my-learner")  # the configurations' table
        expect(row).to_contain_text("+20.0")  # paired with uniform of the same seeds
        page.screenshot(path=str(screenshots / "external-run-compare.png"), full_page=True)
