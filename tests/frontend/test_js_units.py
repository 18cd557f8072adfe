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
