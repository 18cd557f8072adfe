"""examples/independent_learner.py against a real service: its run in compare beside uniform and mgrao-max
of the same system, seeds and episodes, % from uniform paired seed by seed."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import urllib.request

from playwright.sync_api import expect

from mgrao_core.statistics.summary import final_utilities, paired_pct_from_uniform
from tests.frontend.conftest import ROOT, page_at
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_job_view import post_job

SEEDS = 30
EPISODES = 20  # the example's default is 100; fewer keep the test short, through the same code


def finals(server: str, job_id: int) -> dict[str, dict[int, float]]:
    with urllib.request.urlopen(f"{server}/api/jobs/{job_id}/episodes?format=json", timeout=30) as response:
        rows = json.loads(response.read())
    runs: dict[str, dict[int, list[float]]] = {}
    for row in sorted(rows, key=lambda r: r["episode"]):
        runs.setdefault(row["algorithm"], {}).setdefault(row["seed"], []).append(row["utility"])
    return {label: {seed: float(final_utilities(values)[0]) for seed, values in by_seed.items()}
            for label, by_seed in runs.items()}


def test_the_example_learner_is_compared_beside_uniform_and_mgrao_max(browser, server, screenshots):
    compare_example(browser, server, screenshots, "independent_learner.py", ["--seeds", str(SEEDS)], "single",
                    "value-prop", SEEDS, EPISODES, "example-learner-compare.png")


def compare_example(browser, server, screenshots, script: str, arguments: list[str], system: str, label: str,
                    seeds: int, episodes: int, screenshot: str) -> float:
    """Run ``examples/SCRIPT`` against ``server``, then a built-in job of uniform and mgrao-max of the same system,
    seeds and episodes, and check compare shows the example's run beside them, % from uniform paired seed by
    seed; that mean %."""
    example = subprocess.run([sys.executable, str(ROOT / "examples" / script), "--url", server, *arguments,
                              "--episodes", str(episodes)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert example.returncode == 0, example.stderr
    job_id = int(re.match(r"job (\d+): succeeded", example.stdout).group(1))
    built_in = post_job(server, {"system": system, "algorithms": ["uniform", "mgrao-max"], "seeds": seeds,
                                 "episodes": episodes, "name": f"built-in beside {label}"})
    wait_succeeded(server, [built_in])
    ours = finals(server, job_id)[label]
    theirs = finals(server, built_in["id"])
    assert sorted(ours) == sorted(theirs["uniform"]) == list(range(seeds))
    pct = paired_pct_from_uniform(ours, theirs["uniform"])
    expected = sum(pct.values()) / len(pct)

    with page_at(browser, server, height=1000) as page:
        page.goto(f"/#/compare?jobs={built_in['id']},{job_id}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        page.locator("main[data-all-drawn-ms]").wait_for()  # every chart, those below the fold too
        configs = page.eval_on_selector("#compare-chart", """el => el.data
            .filter(t => t.meta && t.meta.kind === 'mean').map(t => t.meta.config)""")
        assert set(configs) == {f"{system} · uniform", f"{system} · mgrao-max", f"{system} · {label} · external"}
        row = page.locator("#pooled-table tr").filter(has_text=label)  # the configurations' table
        expect(row).to_contain_text(f"{expected:+.1f}")  # the mean over the seeds of each seed's %
        expect(row).to_contain_text(str(seeds))  # every seed paired with the built-in job's
        expect(page.locator("#pooled-table tr").filter(has_text="mgrao-max")).to_be_visible()
        page.screenshot(path=str(screenshots / screenshot), full_page=True)
    return expected
