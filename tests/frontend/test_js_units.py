"""Runs the dashboard's pure JavaScript unit tests (node's built-in test runner)."""

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed: the JS unit tests need Node.js >= 18")
def test_js_units():
    proc = subprocess.run(
        ["node", "--test", "tests/frontend/js/"], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed: the JS unit tests need Node.js >= 18")
@pytest.mark.parametrize("module", sorted(p.name for p in (ROOT / "frontend" / "js").glob("*.js")))
def test_every_dashboard_module_parses(module):
    # a syntax error in one module stops the whole dashboard at "Loading…": name the module instead
    source = (ROOT / "frontend" / "js" / module).read_text()
    proc = subprocess.run(["node", "--input-type=module", "--check"], input=source, capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 0, f"{module}: {proc.stderr}"


def _within(expected: object, actual: object) -> bool:
    """``expected`` is ``actual`` except for keys ``actual`` has beyond it (a key the registry adds later)."""
    if isinstance(expected, dict):
        return isinstance(actual, dict) and all(k in actual and _within(v, actual[k]) for k, v in expected.items())
    if isinstance(expected, list):
        return isinstance(actual, list) and len(expected) == len(actual) and all(map(_within, expected, actual))
    return expected == actual


def test_the_js_units_registry_fixture_is_the_cores():
    # tests/frontend/js/algorithms.fixture.json stands for GET /api/algorithms in the JS unit tests
    import json

    from backend.api.routes.systems import algorithm_labels
    from mgrao_core import PRESETS
    from mgrao_core.algorithms import describe_label, registry
    from mgrao_core.params import make_params

    fixture = json.loads((ROOT / "tests" / "frontend" / "js" / "algorithms.fixture.json").read_text())
    assert _within(fixture["families"], registry(None))
    twelve = make_params({"n_parents": 12}, base=PRESETS["single"].params)
    assert _within(fixture["families_single_12"], registry(twelve))
    assert _within(fixture["descriptions"], [describe_label(d["label"]) for d in fixture["descriptions"]])
    assert _within(fixture["roles"], algorithm_labels())
