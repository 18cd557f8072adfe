"""A newcomer's first hour, round 4 (issue 43): what the dashboard shows, seen in a real browser."""

from __future__ import annotations

from tests.frontend.conftest import page_at, running_service
from tests.frontend.test_compare_view import wait_succeeded
from tests.frontend.test_dashboard import api
from tests.frontend.test_job_view import post_job
from tests.frontend.test_newcomer_round2 import console_errors


def test_compare_says_a_job_whose_seeds_are_a_subset_of_anothers_was_read(browser, server, screenshots):
    """Issue 43, item 15: the subset job was read and checked but not listed beside its configuration."""
    whole = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 4,
                              "episodes": 12, "name": "round4 whole"})
    part = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-1:1"], "seeds": [1, 2],
                             "episodes": 12, "name": "round4 part"})
    wait_succeeded(server, [whole, part])
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto(f"/#/compare?jobs={whole['id']},{part['id']}")
        cell = page.locator("td.job-links").first
        cell.wait_for()
        assert cell.locator("a").all_inner_texts() == [f"#{whole['id']}", f"#{part['id']}"]
        checked = cell.locator("span.checked-job")
        assert checked.inner_text() == f"#{part['id']} (checked)"
        assert "none is counted twice" in checked.get_attribute("title")
        page.screenshot(path=str(screenshots / "compare-subset-job-checked.png"), full_page=True)
        assert errors == [], errors


def test_the_runs_table_fits_1024_px_and_sorts_unnamed_jobs_last(browser, server, screenshots):
    """Issue 43, item 14: at 1024 px Duration and Actions were cut off; "Name A-Z" put the unnamed "job 1" first."""
    every = ["uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-5:1", "mgrao-10:1", "mgrao-25:1", "mgrao-max"]
    jobs = [post_job(server, {"system": "large", "algorithms": every, "seeds": 1, "episodes": 5,
                              "name": "every configuration of large", "tags": ["round4-runs", "paper-figure"]}),
            post_job(server, {"system": "single", "algorithms": ["uniform"], "seeds": 1, "episodes": 5,
                              "name": "a named one", "tags": ["round4-runs"]}),
            post_job(server, {"system": "single", "algorithms": ["uniform"], "seeds": 1, "episodes": 5,
                              "tags": ["round4-runs"]})]  # the newest: first until sorted by name
    wait_succeeded(server, jobs)
    with page_at(browser, server, width=1024, height=768) as page:
        errors = console_errors(page)
        page.goto("/#/runs?tag=round4-runs")
        page.locator("table.runs tbody tr").nth(2).wait_for()
        wrap = page.locator(".table-wrap").first
        scroll, client = wrap.evaluate("el => [el.scrollWidth, el.clientWidth]")
        assert scroll <= client, (scroll, client)  # nothing to scroll to: every column on screen
        right = wrap.bounding_box()["x"] + wrap.bounding_box()["width"]
        for header in ("Duration", "Actions"):
            box = page.locator("table.runs thead th", has_text=header).bounding_box()
            assert box["x"] + box["width"] <= right + 0.5, (header, box, right)
        delete = page.locator(f"table.runs tbody tr[data-id='{jobs[0]['id']}'] button", has_text="Delete")
        box = delete.bounding_box()
        assert box["x"] + box["width"] <= right + 0.5, (box, right)
        page.screenshot(path=str(screenshots / "runs-at-1024.png"), full_page=True)
        page.locator("select[name=sort]").select_option("name")
        page.wait_for_function("(id) => document.querySelector('table.runs tbody tr:last-child')?.dataset.id === id",
                               arg=str(jobs[2]["id"]), timeout=30000)
        names = page.locator("table.runs tbody td.job-name a").all_inner_texts()
        assert names == ["a named one", "every configuration of large", f"job {jobs[2]['id']}"], names
        assert errors == [], errors


# seeds of the single system whose mgrao-1:1 interval ends at +23.38%, just below the paper's +23.4%: at one decimal
# both read +23.4% (issue 43, item 12)
CLOSE_CALL_SEEDS = [31, 75, 99, 114, 130, 171, 174]


def test_an_interval_and_the_papers_figure_read_alike_on_the_job_page_and_the_paper_view(browser, tmp_path,
                                                                                          screenshots):
    """Issue 43, item 12: the paper view wrote [+23.28%, +27.99%] "outside" +28.00%, the job page [+23.3%, +28.0%]."""
    from mgrao_core.statistics.report import deciding_digits

    with running_service(tmp_path, workers=1) as base:  # its own: the paper view takes the paper job with most seeds
        job = post_job(base, {"system": "single", "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"],
                              "seeds": CLOSE_CALL_SEEDS, "episodes": 100, "name": "a close call"})
        wait_succeeded(base, [job])
        results = api(base, "GET", f"/jobs/{job['id']}/results?points=10")
        summary = {c["algorithm"]: c["summary"] for c in results["configurations"]}
        low, high = summary["mgrao-1:1"]["pct_ci95"]
        paper = results["paper"]["mgrao-1:1"]
        digits = deciding_digits((low, high), paper)
        assert high < paper and digits == 2, (low, high, paper)  # outside, by less than the first decimal shows
        said = (f"[{low:+.{digits}f}%, {high:+.{digits}f}%]", f"{paper:+.{digits}f}%")
        with page_at(browser, base) as page:
            errors = console_errors(page)
            page.goto(f"/#/jobs/{job['id']}")
            row = page.locator("table.summary tbody tr", has=page.locator("th", has_text="mgrao-1:1"))
            row.locator("td.paper").wait_for()
            cells = row.locator("td").all_inner_texts()  # runs, final mean, its CI, % from uniform, its CI, ...
            on_job_page = (cells[4], row.locator("td.paper").inner_text())
            assert on_job_page == said, on_job_page
            page.screenshot(path=str(screenshots / "job-interval-against-the-paper.png"), full_page=True)
            page.goto("/#/paper")
            row = page.locator('#paper-table tr[data-system="single"][data-algorithm="mgrao-1:1"]')
            row.wait_for()
            cells = row.locator("td").all_inner_texts()
            assert (cells[4], cells[5]) == said and "outside" in cells[6], cells
            assert errors == [], errors


def test_the_job_page_says_what_learning_took_when_max_is_not_the_best_and_where_the_oracle_is_no_bound(
        browser, server, screenshots):
    """Issue 43, items 6-8: "% of max" above 100% unexplained (and always 100% in the runs table's mgrao-max column);
    the oracle's caveat on compare only; no cost of learning, and mgrao-balance's groups nowhere."""
    job = post_job(server, {"system": "multi", "seeds": 3, "episodes": 40, "name": "round4 cost of learning",
                            "algorithms": ["uniform", "mgrao-1:1", "mgrao-max", "mgrao-balance", "oracle"],
                            "params": {"learning_cost": 0.05}, "tags": ["round4-cost"]})
    wait_succeeded(server, [job])
    results = api(server, "GET", f"/jobs/{job['id']}/results?points=10")
    summary = {c["algorithm"]: c["summary"] for c in results["configurations"]}
    above = [a for a, s in summary.items() if a != "mgrao-max" and (s["pct_of_max"] or 0) > 100]
    assert above, summary  # this world has configurations that gain more than mgrao-max
    learning = {c["algorithm"]: c["learning"] for c in results["configurations"]}
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto(f"/#/jobs/{job['id']}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        caveat = page.locator("#oracle-caveat")
        assert "no upper bound" in caveat.inner_text()
        assert caveat.locator("li").all_inner_texts() == results["oracle_caveats"]
        note = page.inner_text("#max-note")
        assert note.startswith("mgrao-max is not the best here:"), note
        for algorithm in above:
            assert f"{algorithm} ({summary[algorithm]['pct_of_max']:.1f}%)" in note, note
        rows = {r.locator("th").inner_text(): r.locator("td").all_inner_texts()
                for r in page.locator("#learning-table tbody tr").all()}
        assert set(rows) == {"mgrao-1:1", "mgrao-max", "mgrao-balance"}, rows
        assert rows["mgrao-1:1"] == ["1", f"{100 * learning['mgrao-1:1']['taken']['mean']:.1f}%"]
        assert rows["mgrao-max"][0] == "10" and rows["mgrao-max"][1] == "5.0%"  # mgrao-max pays learning_cost
        ended = sorted(learning["mgrao-balance"]["groups"].items(), key=lambda kv: int(kv[0]))
        assert rows["mgrao-balance"][0] == "; ".join(f"{g} {'group' if g == '1' else 'groups'}: {n} of 9 children"
                                                     for g, n in ended), rows
        page.locator("#learning-table").scroll_into_view_if_needed()
        page.screenshot(path=str(screenshots / "job-learning-max-oracle.png"), full_page=True)
        page.goto("/#/runs?tag=round4-cost&result=mgrao-max")
        page.locator("table.runs tbody tr").first.wait_for()
        headers = page.locator("table.runs thead th").all_inner_texts()
        assert any(h.startswith("% from uniform") for h in headers), headers
        assert not any(h.startswith("% of max") for h in headers), headers  # 100% by definition: not a column
        assert errors == [], errors


def test_a_hundred_seeds_are_drawn_as_a_faint_sample_beneath_the_means_under_a_true_caption(browser, server,
                                                                                           screenshots):
    """Issue 43, item 9: 400 opaque seed lines hid the means and bands, under "Lines: mean over seeds"."""
    job = post_job(server, {"system": "single", "algorithms": ["uniform", "mgrao-1:1", "mgrao-2:1", "mgrao-max"],
                            "seeds": 100, "episodes": 30, "name": "round4 a hundred seeds"})
    wait_succeeded(server, [job])
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto(f"/#/jobs/{job['id']}?seeds=1")
        page.locator("#utility-chart[data-rendered]").wait_for()
        kinds = page.eval_on_selector("#utility-chart", "el => el.data.map(t => t.meta.kind)")
        assert kinds.count("seed") == 4 * 20, kinds.count("seed")  # a sample of each configuration's seeds
        assert kinds.index("band") > max(i for i, k in enumerate(kinds) if k == "seed")  # beneath every band
        alphas = page.eval_on_selector("#utility-chart", """el => el.data.filter(t => t.meta.kind === 'seed')
            .map(t => Number(t.line.color.split(',').pop().replace(')', '')))""")
        assert max(alphas) <= 0.2, max(alphas)  # faint
        caption = page.inner_text("#smoothing-note")
        assert caption.startswith("Thick lines: mean over seeds; bands: its 95% interval."), caption
        assert "Faint lines beneath: 20 of each configuration’s 100 seeds" in caption, caption
        page.screenshot(path=str(screenshots / "job-a-hundred-seeds.png"), full_page=True)
        assert errors == [], errors
