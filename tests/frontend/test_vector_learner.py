"""examples/vector_learner.py against a real service: 256 worlds trained at once through the vector environment,
its run in compare beside uniform and mgrao-max of the same system, seeds and episodes, paired seed by seed."""

from __future__ import annotations

import re
import subprocess
import sys

from playwright.sync_api import expect

from mgrao_core.stats import paired_pct_from_uniform
from tests.frontend.conftest import ROOT, page_at
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_independent_learner import finals
from tests.frontend.test_job_view import post_job

WORLDS = 256
EPISODES = 40  # the example's default is 200; fewer keep the test short, through the same code


def test_the_vector_learner_is_compared_beside_uniform_and_mgrao_max(browser, server, screenshots):
    example = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "vector_learner.py"), "--url", server,
         "--worlds", str(WORLDS), "--episodes", str(EPISODES)],
        capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert example.returncode == 0, example.stderr
    job_id = int(re.match(r"job (\d+): succeeded", example.stdout).group(1))
    built_in = post_job(server, {"system": "large", "algorithms": ["uniform", "mgrao-max"], "seeds": WORLDS,
                                 "episodes": EPISODES, "name": "built-in beside the vector learner"})
    wait_succeeded(server, [built_in])
    ours = finals(server, job_id)["softmax-value"]
    theirs = finals(server, built_in["id"])
    assert sorted(ours) == sorted(theirs["uniform"]) == list(range(WORLDS))
    pct = paired_pct_from_uniform(ours, theirs["uniform"])
    expected = sum(pct.values()) / len(pct)

    with page_at(browser, server, height=1000) as page:
        page.goto(f"/#/compare?jobs={built_in['id']},{job_id}")
        page.locator("#compare-chart[data-rendered]").wait_for()
        page.locator("main[data-all-drawn-ms]").wait_for()  # every chart, those below the fold too
        configs = page.eval_on_selector("#compare-chart", """el => el.data
            .filter(t => t.meta && t.meta.kind === 'mean').map(t => t.meta.config)""")
        assert set(configs) == {"large · uniform", "large · mgrao-max", "large · softmax-value · external"}
        row = page.locator("#pooled-table tr").filter(has_text="softmax-value")
        expect(row).to_contain_text(f"{expected:+.1f}")  # the mean over the 256 seeds of each seed's %
        expect(row).to_contain_text(f"{WORLDS}")  # every seed paired with the built-in job's
        page.screenshot(path=str(screenshots / "vector-learner-compare.png"), full_page=True)
    print(f"softmax-value on large, {WORLDS} worlds x {EPISODES} episodes: {expected:+.1f}% from uniform "
          f"(mean of paired per-seed %)")
