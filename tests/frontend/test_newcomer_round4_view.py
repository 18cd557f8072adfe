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


def test_the_job_page_says_while_the_engine_compiles_for_it_and_shows_queued_compiling_and_running_apart(
        browser, tmp_path, screenshots):
    """Issue 43, items 2 and 11: a job sat at "Running: 0% done" while a kernel compiled for the first time, and
    its Duration (132 ms) hid the wait for the warm-up and the compile."""
    from tests.support.waiting import wait_until

    # a service of its own, with an empty numba cache as after an install: its worker compiles the paper's
    # configurations as it warms up; a job of uniform alone is a combination met for the first time
    with running_service(tmp_path, workers=1, NUMBA_CACHE_DIR=str(tmp_path / "numba")) as base:
        job = post_job(base, {"system": "single", "algorithms": ["uniform"], "seeds": 2, "episodes": 20,
                              "name": "round4 first of its kind"})
        with page_at(browser, base) as page:
            errors = console_errors(page)
            page.goto(f"/#/jobs/{job['id']}")
            status = page.locator("#job-waiting")
            said = wait_until(lambda: "Compiling the engine" in (text := status.inner_text()) and text, 900,
                              "the job page to say that the engine compiles for the job",
                              details=lambda: f"page says: {status.inner_text()}")
            assert said.startswith("Running: Compiling the engine for the fixed allocations: first time only, "
                                   "about "), said
            assert "so far" in said and "mgrao compile" in said
            page.screenshot(path=str(screenshots / "job-compiling.png"))
            wait_succeeded(base, [job])
            page.locator("#utility-chart[data-rendered]").wait_for(timeout=120000)
            meta = {k.upper(): v for k, v in zip(page.locator(".meta dt").all_inner_texts(),
                                                 page.locator(".meta dd").all_inner_texts(), strict=True)}
            stored = api(base, "GET", f"/jobs/{job['id']}")
            assert stored["compile_s"] > 0 and stored["compiling"] is None
            assert meta["COMPILING"] != "none" and meta["QUEUED"] != "–" and meta["RUNNING"] != "–", meta
            assert "DURATION" not in meta, meta
            page.screenshot(path=str(screenshots / "job-queued-compiling-running.png"), full_page=True)
            again = post_job(base, {"system": "single", "algorithms": ["uniform"], "seeds": 2, "episodes": 20})
            wait_succeeded(base, [again])
            assert api(base, "GET", f"/jobs/{again['id']}")["compile_s"] is None  # loaded, not compiled again
            assert errors == [], errors


def test_an_until_jobs_header_says_its_seeds_of_at_most_how_many(browser, server, screenshots):
    """Issue 43, item 11: an until-job's header said SEEDS 20 while its configuration said "500 seeds"."""
    job = post_job(server, {"system": "single", "episodes": 30, "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"],
                            "until": {"half_width": 50}, "name": "round4 until"})
    wait_succeeded(server, [job])
    stored = api(server, "GET", f"/jobs/{job['id']}")
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto(f"/#/jobs/{job['id']}")
        page.locator("#utility-chart[data-rendered]").wait_for()
        meta = {k.upper(): v for k, v in zip(page.locator(".meta dt").all_inner_texts(),
                                             page.locator(".meta dd").all_inner_texts(), strict=True)}
        assert meta["SEEDS"] == f"{stored['stopped']['seeds']} of at most {stored['until']['max_seeds']}", meta
        assert errors == [], errors


def saved(server: str, body: dict) -> None:
    """Save a system on the session's server (an earlier test's is kept)."""
    try:
        api(server, "POST", "/systems/saved", body)
    except Exception:  # noqa: BLE001 - saved by an earlier run of the session's server
        pass


def test_a_saved_systems_defaults_can_be_run_and_a_refused_value_marks_its_box_alone(browser, server, screenshots):
    """Issue 43, item 3: choosing large30 kept large's x "1, 2, 5, 10, 25"; Run refused mgrao-25:1 and outlined every
    configuration box red."""
    saved(server, {"name": "large30", "base": "large", "params": {"n_parents": 30}})
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto("/#/new")
        page.get_by_label("System preset").select_option("large30")
        x = page.locator("input.argument-values[data-template='mgrao-{x}:1']")
        check = page.locator("small.argument-check").first
        page.wait_for_function("(el) => el.textContent.includes('Valid x here: 1, 2, 3, 5, 6, 10, 15, 30.')",
                               arg=check.element_handle())
        assert x.input_value() == "1, 2, 5, 10", x.input_value()  # large's, those valid for 30 parents
        assert "not valid" not in check.inner_text()
        x.fill("1, 2, 5, 10, 25")
        page.get_by_role("button", name="Run experiment").click()
        error = page.locator("input.argument-values[data-template='mgrao-{x}:1'] ~ .field-error")
        error.wait_for()
        page.wait_for_function("(el) => el.textContent.includes('mgrao-25:1')", arg=error.element_handle())
        assert error.inner_text().startswith("mgrao-25:1: x must be a divisor of n_parents = 30"), error.inner_text()
        assert "algorithms[" not in page.inner_text(".newjob")
        assert x.get_attribute("aria-invalid") == "true"
        assert page.locator("fieldset.algos.invalid").count() == 0  # the configurations' box is not all red
        assert page.locator("fieldset.algos input[type=checkbox][aria-invalid='true']").count() == 0
        page.screenshot(path=str(screenshots / "new-experiment-saved-system-defaults.png"), full_page=True)
        x.fill("1, 2, 5, 10")  # the defaults again: it runs
        page.get_by_role("button", name="Run experiment").click()
        page.wait_for_url("**/#/jobs/*")
        assert errors == [], errors


def test_every_refused_field_is_said_at_once_in_its_own_words(browser, server, screenshots):
    """Issue 43, item 5: x "1, abc, 3", seeds -5, episodes 10,000,000 said only "not a value: abc"; -5 passed the
    browser; messages quoted internal paths; a banner said "see the marked fields" with none marked."""
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto("/#/new")
        page.get_by_label("System preset").select_option("single")
        seeds = page.get_by_label("Seeds (number of runs)")
        seeds.fill("-5")
        seeds_error = page.locator(f"#{seeds.get_attribute('id')}-err")
        assert seeds_error.inner_text() == "Must be a whole number from 1 to 1000 (got -5)."  # at once, as typed
        page.get_by_label("Episodes per run").fill("10000000")
        page.locator("input.argument-values[data-template='mgrao-{x}:1']").fill("1, abc, 3")
        page.get_by_role("button", name="Run experiment").click()
        summary = page.locator(".error-summary:not(.own-system > .error-summary)")
        summary.get_by_text("see the marked fields").wait_for(timeout=10000)
        text = " | ".join(page.locator(".field-error").all_inner_texts())
        for said in ("abc: not a value of x", "seeds: must be at least 1 (got -5)",
                     "episodes: must be at most 100000 (got 10000000)"):
            assert said in text, text
        invalid = page.locator("[aria-invalid='true']").evaluate_all("els => els.map(e => e.dataset.field || e.name)")
        assert {"seeds", "episodes", "algorithms:mgrao-{x}:1"} <= set(invalid), invalid
        page.screenshot(path=str(screenshots / "new-experiment-every-error-at-once.png"), full_page=True)
        assert errors == [], errors  # the experiment is checked (200), never refused with a 422
        # a study refused for a trial (POST /api/studies answers 422: the console logs it), in the fields' words
        page.goto("/#/studies/new")
        page.get_by_label("System preset").select_option("large")
        for sweep in page.locator("input[data-sweep]:checked").all():
            sweep.uncheck()
        page.locator("input[data-sweep='n_parents']").check()
        page.get_by_label("n_parents: range or values").select_option("values")
        page.get_by_label("n_parents values").fill("15, 50")
        page.get_by_role("button", name="Start study").click()
        alert = page.locator(".error-summary .notice.error").first
        alert.wait_for(timeout=10000)
        said = alert.inner_text()
        assert "the parameters swept: a trial" in said, said
        assert "with n_parents = 15 is not a valid experiment: mgrao-2:1: x must be a divisor of n_parents = 15" \
            in said, said
        assert "{" not in said and "algorithms[" not in said and "space." not in said, said
        assert "see the marked fields" not in said or page.locator("[aria-invalid='true']").count() > 0, said


def test_the_systems_page_lists_opens_edits_and_deletes_a_saved_system(browser, server, screenshots):
    """Issue 43, item 4: the dashboard could save a system but not list, open, edit or delete one."""
    saved(server, {"name": "round4-sys", "base": "single", "params": {"n_parents": 5},
                   "description": "single with five parents"})
    job = post_job(server, {"system": "round4-sys", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 1, "episodes": 5,
                            "name": "on round4-sys"})
    wait_succeeded(server, [job])
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto("/#/runs")
        page.get_by_role("link", name="Systems").click()
        row = page.locator("#systems-table tbody tr[data-name='round4-sys']")
        row.wait_for()
        assert row.locator("td").all_inner_texts()[:3] == ["single", "n_parents 5", "1"]
        row.get_by_role("link", name="round4-sys").click()
        page.locator("#system-params").wait_for()
        differs = page.locator("#system-params tr.differs")
        assert differs.count() == 1 and differs.locator("td").all_inner_texts() == ["5", "10"]
        assert page.locator("#system-jobs a").all_inner_texts() == ["on round4-sys"]
        page.screenshot(path=str(screenshots / "system-page.png"), full_page=True)
        # edit: a refused value is said beside it; a valid one is saved and shown
        page.locator("#edit-system").click()
        value = page.get_by_label("n_parents of round4-sys")
        value.fill("0")
        page.get_by_role("button", name="Save").click()
        error = page.locator("tr[data-param='n_parents'] .field-error")
        page.wait_for_function("(el) => el.textContent.includes('n_parents')", arg=error.element_handle())
        assert "n_parents: must be" in error.inner_text() and value.get_attribute("aria-invalid") == "true"
        value.fill("2")
        page.get_by_role("button", name="Save").click()
        page.locator("#system-params tr.differs td.mine", has_text="2").wait_for()
        assert api(server, "GET", "/systems/saved/round4-sys")["params"] == {"n_parents": 2}
        # delete: the confirmation says what becomes of the job that ran it
        page.locator("#delete-system").click()
        dialog = page.locator("dialog")
        said = dialog.inner_text()
        assert "The one job that ran it keeps its results, its configuration (single with these values) and its " \
               "tag system:round4-sys" in said, said
        dialog.get_by_role("button", name="Delete the system").click()
        page.wait_for_url("**/#/systems")
        page.locator("#systems-table, .notice.empty").first.wait_for()
        assert page.locator("#systems-table tbody tr[data-name='round4-sys']").count() == 0
        kept = api(server, "GET", f"/jobs/{job['id']}")
        assert kept["status"] == "succeeded" and kept["saved_system"] == "round4-sys"
        assert [e for e in errors if "status of 422" not in e] == [], errors  # the refused edit's answer alone


def test_a_study_draws_nothing_it_does_not_know_and_says_what_it_cannot_tell(browser, server, screenshots):
    """Issue 43, item 10: "null" above the trials; invented axes before any trial; importance 1.00 after 4 trials and
    a best on 3 seeds with a wide interval, both without a warning."""
    from tests.support.waiting import wait_until

    definition = {"name": "round4 four trials", "method": "grid",
                  "base": {"system": "single", "seeds": 3, "episodes": 20},
                  "space": {"learning_rate": {"values": [0.05, 0.1, 0.2, 0.4]}},
                  "objective": {"metric": "pct_from_uniform", "configuration": "mgrao-max"}}
    study = api(server, "POST", "/studies", definition)["study"]
    wait_until(lambda: api(server, "GET", f"/studies/{study['id']}?trials=false")["study"]["status"] != "running",
               300, "the study to finish")
    # one stopped before any trial ended: nothing to draw
    empty = api(server, "POST", "/studies", definition | {"name": "round4 stopped at once",
                                                          "base": {"system": "large", "seeds": 30, "episodes": 500}})
    api(server, "POST", f"/studies/{empty['study']['id']}/cancel")
    with page_at(browser, server) as page:
        errors = console_errors(page)
        page.goto(f"/#/studies/{study['id']}")
        page.locator(".study-plots[data-rendered]").wait_for()
        assert "null" not in page.inner_text("section[aria-labelledby='h-trials']")
        note = page.inner_text("#importance-note")
        assert note.startswith("Not told apart from noise with 4 trials: learning_rate (η² 1.00, p = 1.00)"), note
        best = dict(zip(page.locator(".meta dt").all_inner_texts(), page.locator(".meta dd").all_inner_texts(),
                        strict=True))
        said = next(v for k, v in best.items() if k.upper() == "BEST")
        assert "(95% interval over 3 seeds) at trial" in said, said
        page.screenshot(path=str(screenshots / "study-what-it-cannot-tell.png"), full_page=True)
        page.goto(f"/#/studies/{empty['study']['id']}")
        page.locator(".study-plots[data-rendered]").wait_for()
        assert api(server, "GET", f"/studies/{empty['study']['id']}/plots")["trials"] == 0  # cancelled long before
        assert page.inner_text("#plots-note").startswith("No trial has an objective yet")
        assert page.locator(".study-plots .js-plotly-plot:visible, .study-plots svg.main-svg:visible").count() == 0
        assert errors == [], errors
