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
