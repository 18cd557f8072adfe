"""The dashboard's partial plotly.js: served in place of the full bundle, and enough for every chart.

The bundle registers only the trace types the dashboard draws (tools/plotly-bundle). plotly.js draws
a trace of a type it does not know as nothing at all, without an error, so these tests look at every
chart of every view that draws one, in headless Chromium against a real ``mgrao serve`` with real
workers, and check each trace's type against what the loaded plotly.js registers.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from backend.api.static import frontend_dir, full_plotly_js, plotly_build
from tests.frontend.test_dashboard import api, wait_job
from tests.frontend.test_job_view import wait_for
from tests.frontend.test_studies_view import wait_study

ROOT = Path(__file__).resolve().parents[2]
MANIFEST = ROOT / "frontend" / "vendor" / "plotly-dashboard.json"
TRACES_IN_VIEW = """() => ({
  registered: Object.keys(window.Plotly.PlotSchema.get().traces).sort(),
  used: [...document.querySelectorAll('.js-plotly-plot')].flatMap(el => (el.data || []).map(t => t.type || 'scatter')),
  charts: document.querySelectorAll('.js-plotly-plot').length,
  script: document.getElementById('plotly-js')?.src || '',
})"""


def _traces(page, what: str) -> dict:
    wait_for(lambda: page.evaluate("() => !!window.Plotly && document.querySelectorAll('.js-plotly-plot "
                                   ".main-svg').length > 0"), 60, f"plotly.js to draw the {what}")
    return page.evaluate(TRACES_IN_VIEW)


@pytest.mark.browser
@pytest.mark.slow
def test_every_chart_of_every_view_uses_a_trace_type_the_served_bundle_registers(page, server, screenshots):
    manifest = json.loads(MANIFEST.read_text())
    first = api(server, "POST", "/jobs", {"system": "single", "algorithms": ["uniform", "oracle", "mgrao-1:1",
                                                                              "mgrao-max"],
                                          "seeds": 3, "episodes": 20, "name": "bundle check a"})
    second = api(server, "POST", "/jobs", {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3,
                                           "episodes": 20, "name": "bundle check b", "params": {"learning_rate": 0.2}})
    study = api(server, "POST", "/studies", {
        "name": "bundle check", "method": "grid",
        "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 10},
        "space": {"learning_rate": {"values": [0.05, 0.2]}, "trace_decay": {"values": [0.5, 0.9]}},
        "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform", "direction": "maximize"},
    })["study"]["id"]
    for job in (first, second):
        assert wait_job(server, job["id"])["status"] == "succeeded"
    wait_study(server, study)

    page.set_viewport_size({"width": 1280, "height": 900})
    seen: dict[str, dict] = {}
    page.goto(f"/#/jobs/{first['id']}")
    page.locator("#weights-bars .main-svg").first.wait_for(timeout=60000)
    page.locator("#weights-heatmap .main-svg").first.wait_for(timeout=60000)
    seen["job"] = _traces(page, "job view")
    page.goto(f"/#/compare?jobs={first['id']},{second['id']}")
    page.locator("main[data-all-drawn-ms]").wait_for(timeout=60000)  # the bars below the fold too
    seen["compare"] = _traces(page, "compare view")
    page.goto(f"/#/studies/{study}")
    wait_for(lambda: page.evaluate("() => document.querySelectorAll('.js-plotly-plot').length") >= 4, 60,
             "the study's plots")
    seen["study"] = _traces(page, "study view")
    page.screenshot(path=str(screenshots / "plotly-bundle-study.png"), full_page=True)

    for view, found in seen.items():
        assert found["script"].endswith(plotly_build().url), (view, found["script"])  # the partial bundle
        assert found["registered"] == sorted(manifest["traces"]), (view, found["registered"])
        assert found["charts"] >= 2 and found["used"], (view, found)
        assert set(found["used"]) <= set(found["registered"]), (view, found["used"])
    assert {t for found in seen.values() for t in found["used"]} == set(manifest["traces"])  # none shipped unused


def test_the_served_plotly_is_the_partial_bundle_built_from_the_installed_plotly_js():
    from plotly.offline import get_plotlyjs_version

    manifest = json.loads(MANIFEST.read_text())
    assert manifest["plotly_js"] == get_plotlyjs_version(), (
        "the plotly package pinned in pyproject.toml ships another plotly.js than the dashboard's bundle: "
        "rebuild it with tools/plotly-bundle/build.sh")
    build = plotly_build()
    assert build.path == frontend_dir() / "vendor" / "plotly-dashboard.min.js"
    assert build.traces == tuple(manifest["traces"])
    assert build.path.stat().st_size < full_plotly_js().stat().st_size / 3


def test_a_bundle_of_another_plotly_js_version_or_altered_falls_back_to_the_full_bundle(tmp_path, monkeypatch):
    from backend.api import static

    vendor = tmp_path / "vendor"
    shutil.copytree(ROOT / "frontend" / "vendor", vendor)
    monkeypatch.setattr(static, "frontend_dir", lambda: tmp_path)
    version = json.loads(MANIFEST.read_text())["plotly_js"]
    assert static._partial_bundle(version) is not None
    assert static._partial_bundle("0.0.1") is None  # another plotly.js: the package's full bundle is served
    (vendor / "plotly-dashboard.min.js").write_bytes(b"/* altered */")
    assert static._partial_bundle(version) is None  # not what the manifest describes
    (vendor / "plotly-dashboard.json").unlink()
    assert static._partial_bundle(version) is None


@pytest.mark.slow
def test_the_bundle_rebuilds_to_the_same_bytes(tmp_path):
    if shutil.which("npm") is None or shutil.which("node") is None:
        pytest.skip("node and npm are needed to rebuild the bundle (apt-get install nodejs npm)")
    build = tmp_path / "plotly-bundle"
    shutil.copytree(ROOT / "tools" / "plotly-bundle", build, ignore=shutil.ignore_patterns("node_modules"))
    out = tmp_path / "vendor"
    done = subprocess.run(["bash", str(build / "build.sh"), str(out)], capture_output=True, text=True, timeout=600,
                          check=False)
    if done.returncode != 0 and "npm" in done.stderr and ("ETIMEDOUT" in done.stderr or "ENOTFOUND" in done.stderr
                                                          or "EAI_AGAIN" in done.stderr):
        pytest.skip(f"the npm registry could not be reached: {done.stderr.strip()[-300:]}")
    assert done.returncode == 0, done.stdout + done.stderr
    assert sorted(p.name for p in out.iterdir()) == ["plotly-dashboard.json", "plotly-dashboard.min.js"]  # no CSS
    assert json.loads((out / "plotly-dashboard.json").read_text()) == json.loads(MANIFEST.read_text())
    assert (out / "plotly-dashboard.min.js").read_bytes() == (ROOT / "frontend" / "vendor"
                                                              / "plotly-dashboard.min.js").read_bytes()
