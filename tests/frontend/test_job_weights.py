"""The job view's learned weights: one chosen seed (not the mean that washes each seed's structure
out), the oracle's allocation beside the learner's for that seed, and thinned labels at 50 groups.

Real `mgrao serve` with real workers, a real SQLite file, headless Chromium.
"""

from __future__ import annotations

import json
import urllib.request

from tests.frontend.test_job_view import post_job, wait_for

ALGORITHMS = ["uniform", "oracle", "mgrao-1:1", "mgrao-max"]


def get(base: str, path: str) -> dict:
    with urllib.request.urlopen(f"{base}{path}", timeout=30) as response:
        return json.loads(response.read())


def bars(page) -> dict[str, list[float]]:
    return page.eval_on_selector("#weights-bars", "el => Object.fromEntries((el.data || []).map("
                                 "t => [t.meta.config, Array.from(t.y)]))")


def test_weights_of_one_seed_beside_the_oracle(page, server, screenshots):
    job = post_job(server, {"system": "large", "algorithms": ALGORITHMS, "seeds": [4, 8, 15], "episodes": 40,
                            "name": "weights per seed"})
    wait_for(lambda: get(server, f"/api/jobs/{job['id']}")["status"] == "succeeded", 120, "the job to finish")
    one = {seed: {c["algorithm"]: c for c in get(server, f"/api/jobs/{job['id']}/weights?seed={seed}")
                  ["configurations"]} for seed in (4, 8)}
    page.set_viewport_size({"width": 1280, "height": 900})
    page.goto(f"/#/jobs/{job['id']}")
    page.locator("#weights-bars .main-svg").first.wait_for(timeout=60000)
    seed = page.get_by_label("Seed", exact=True)
    configuration = page.get_by_label("Configuration", exact=True).and_(page.locator("select"))
    wait_for(lambda: seed.locator("option").count() == 4, 30, "the stored seeds in the selector")
    assert seed.locator("option").all_inner_texts() == ["seed 4", "seed 8", "seed 15", "mean over 3 seeds"]
    assert seed.input_value() == "4"  # one seed by default, not the mean
    assert configuration.input_value() == "mgrao-max"  # the most parent groups: 50

    # the learner's combined weights beside the oracle's allocation, both for seed 4, as stored
    wait_for(lambda: set(bars(page)) == {"mgrao-max", "oracle"}, 30, "the learner and the oracle in the bars")
    assert bars(page)["oracle"] == one[4]["oracle"]["combined"][0]
    assert bars(page)["mgrao-max"] == one[4]["mgrao-max"]["combined"][0]
    heat = page.eval_on_selector("#weights-heatmap", "el => ({z: el.data[0].z, dtick: el.layout.yaxis.dtick, "
                                 "labels: el.querySelectorAll('.yaxislayer-above .ytick').length})")
    assert heat["z"] == one[4]["mgrao-max"]["groups"][0]
    assert heat["dtick"] > 1 and 5 <= heat["labels"] <= 20, heat  # 50 groups: thinned, not 50 labels
    assert "Seed 4" in page.locator("#weights-seed-note").inner_text()
    page.locator("#h-w").scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "weights-seed.png"))

    # another seed: its own structure (the oracle's allocation differs), as stored
    seed.select_option("8")
    wait_for(lambda: bars(page).get("oracle") == one[8]["oracle"]["combined"][0], 30, "seed 8's oracle")
    assert one[8]["oracle"]["combined"] != one[4]["oracle"]["combined"]
    assert bars(page)["mgrao-max"] == one[8]["mgrao-max"]["combined"][0]

    # the mean is still there, saying what it hides
    results = get(server, f"/api/jobs/{job['id']}/results")
    mean = {c["algorithm"]: c["weights"]["combined"][0] for c in results["configurations"]}
    seed.select_option("mean")
    wait_for(lambda: bars(page).get("oracle") == mean["oracle"], 30, "the mean over seeds")
    assert "washes out" in page.locator("#weights-seed-note").inner_text()

    # a learner without groups shows its combined weights only; the choice of seed holds
    configuration.select_option("uniform")
    wait_for(lambda: "stores no group weights" in page.locator("#weights-heat-note").inner_text(), 30, "the note")
    assert page.locator("#weights-heatmap").is_hidden()


def test_a_job_without_the_oracle_says_so(page, server):
    job = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 20})
    wait_for(lambda: get(server, f"/api/jobs/{job['id']}")["status"] == "succeeded", 120, "the job to finish")
    page.goto(f"/#/jobs/{job['id']}")
    page.locator("#weights-bars .main-svg").first.wait_for(timeout=60000)
    wait_for(lambda: "did not run the oracle" in page.locator("#weights-seed-note").inner_text(), 30, "the note")
    assert set(bars(page)) == {"mgrao-max"}


def test_adaptive_groups_show_their_membership_over_the_run(page, server, screenshots):
    job = post_job(server, {"system": "large", "algorithms": ["uniform", "mgrao-5:1", "mgrao-adaptive:5"],
                            "seeds": [3], "episodes": 60, "params": {"regroup_every": 5},
                            "name": "adaptive membership"})
    wait_for(lambda: get(server, f"/api/jobs/{job['id']}")["status"] == "succeeded", 120, "the job to finish")
    stored = {c["algorithm"]: c for c in get(server, f"/api/jobs/{job['id']}/weights")["configurations"]}
    membership = stored["mgrao-adaptive:5"]["membership"]
    page.set_viewport_size({"width": 1280, "height": 1200})
    page.goto(f"/#/jobs/{job['id']}")
    page.locator("#weights-bars .main-svg").first.wait_for(timeout=60000)
    configuration = page.get_by_label("Configuration", exact=True).and_(page.locator("select"))
    configuration.select_option("mgrao-5:1")
    assert page.locator("#membership-heatmap").is_hidden()  # fixed groups: no membership
    configuration.select_option("mgrao-adaptive:5")
    page.locator("#membership-heatmap .main-svg").first.wait_for(timeout=30000)
    figure = page.eval_on_selector("#membership-heatmap", "el => ({z: el.data[0].z, x: Array.from(el.data[0].x)})")
    records = membership["children"][0]  # 12 records: episode 0 and the regroups at 5, 10, ..., 55
    assert figure["x"] == [i * membership["every"] for i in range(len(records))] and len(records) == 12
    assert figure["z"] == [[r[p] for r in records] for p in range(50)]  # parents by records, as stored
    assert "Group membership of child 0 under mgrao-adaptive:5, seed 3" in page.locator("#membership-note").inner_text()
    page.locator("#membership-heatmap").scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "adaptive-membership.png"), full_page=True)


def test_several_resources_show_one_heatmap_per_resource(page, server, screenshots):
    # the system picker offers the multi-resource preset (learned from GET /api/systems), and its job view draws
    # one heatmap of the parent-group weights per resource, titled by resource, each as stored
    page.goto("/#/new")
    picker = page.get_by_label("System preset")
    picker.wait_for(timeout=30000)
    assert "multi-resource" in picker.locator("option").all_inner_texts() or "multi-resource" in [
        o.get_attribute("value") for o in picker.locator("option").all()]
    job = post_job(server, {"system": "multi-resource", "algorithms": ALGORITHMS, "seeds": [2, 5], "episodes": 30,
                            "params": {"resource_credit": "by-share"}, "name": "weights per resource"})
    wait_for(lambda: get(server, f"/api/jobs/{job['id']}")["status"] == "succeeded", 120, "the job to finish")
    stored = {c["algorithm"]: c for c in get(server, f"/api/jobs/{job['id']}/weights?seed=2")["configurations"]}
    page.set_viewport_size({"width": 1280, "height": 1200})
    page.goto(f"/#/jobs/{job['id']}")
    page.locator("#weights-bars .main-svg").first.wait_for(timeout=60000)
    heatmaps = page.locator("[data-testid=weights-resource-heatmap]")
    wait_for(lambda: heatmaps.count() == 2, 30, "one heatmap per resource")
    page.locator("#weights-heatmap-resource-1 .main-svg").first.wait_for(timeout=30000)
    for r in (0, 1):
        drawn = page.eval_on_selector(f"#weights-heatmap-resource-{r}",
                                      "el => ({z: el.data[0].z, title: el.layout.title.text})")
        assert drawn["title"].startswith(f"Resource {r}")
        assert drawn["z"] == stored["mgrao-max"]["resources"][r]["groups"][0]
    assert stored["mgrao-max"]["resources"][0]["groups"] != stored["mgrao-max"]["resources"][1]["groups"]
    assert page.locator("#weights-heatmap").is_hidden()  # the single heatmap gives way to one per resource
    page.locator("#weights-resource-heatmaps").scroll_into_view_if_needed()
    page.screenshot(path=str(screenshots / "weights-resources.png"))
    # a configuration without group weights draws none
    page.get_by_label("Configuration", exact=True).and_(page.locator("select")).select_option("uniform")
    wait_for(lambda: heatmaps.count() == 0, 30, "no heatmap for uniform")
