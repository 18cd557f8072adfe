"""Schemathesis, an outside judge, against a live ``mgrao serve`` on SQLite and PostgreSQL: no failure.

It reads the service's own OpenAPI document, generates requests from it (valid and invalid, then
sequences along its links) and runs every check on the answers: no server error, only documented
status codes, content types and headers, answers that match their schemas, invalid data refused,
valid data accepted, 405 with Allow for undocumented methods, auth enforced where declared. Run from
the repository root, so that it reads schemathesis.toml (which says what the document cannot: see
there). Bounded: EXAMPLES cases per operation and phase, a fixed seed. The SQLite service runs
without a token (writes need none: the document says so); the PostgreSQL one with MGRAO_API_TOKEN,
the token given to Schemathesis as a client would send it, so that it also checks that writes
without it, or with a wrong one, are refused.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from backend_helpers import TOKEN, Service

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = 10
SEED = 1
DEADLINE_S = 600


@pytest.mark.slow
def test_schemathesis_finds_no_failure(service: Service) -> None:
    token = service.db_url.startswith("postgresql")
    if token:
        service.env["MGRAO_API_TOKEN"] = TOKEN
    service.start_server()
    command = [sys.executable, "-m", "schemathesis.cli", "run", f"{service.base}/openapi.json", "--checks", "all",
               "--max-examples", str(EXAMPLES), "--seed", str(SEED), "--workers", "1", "--no-color",
               "--request-timeout", "30", *(["--header", f"Authorization: Bearer {TOKEN}"] if token else [])]
    before = written_state()
    storage = service.tmp_path / "hypothesis"  # Hypothesis's own Unicode tables go where this says
    try:
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=DEADLINE_S, check=False,
                              env=dict(os.environ, HYPOTHESIS_STORAGE_DIRECTORY=str(storage)))
    except subprocess.TimeoutExpired as error:
        raise AssertionError(f"schemathesis did not finish within {DEADLINE_S} s:\n{error.stdout}") from None
    output = done.stdout + done.stderr
    assert f"Configuration:    {ROOT / 'schemathesis.toml'}" in output, output[-5000:]
    counted = re.search(r"(\d+) generated, (.*)", output)
    assert counted, f"no test cases counted:\n{output[-5000:]}"
    print(f"schemathesis ({service.db_url.split(':')[0]}, token {token}): {counted.group(0)}")
    assert done.returncode == 0 and "failure" not in counted.group(2), f"{counted.group(0)}\n{output[-20000:]}"
    assert int(counted.group(1)) > 0, output[-5000:]
    # run from the repository root, it keeps nothing there (schemathesis.toml: no example database, no cache),
    # and with Hypothesis's storage elsewhere nothing but its Unicode tables is kept there either
    assert written_state() == before, f"schemathesis wrote into the checkout: {written_state() - before}"
    assert {p.name for p in storage.iterdir()} <= {"unicode_data", ".gitignore"}, list(storage.rglob("*"))


def written_state() -> set[str]:
    """What Hypothesis or Schemathesis could have written under the repository root: their directories' files."""
    return {str(p.relative_to(ROOT)) for name in (".hypothesis", ".schemathesis") if (ROOT / name).exists()
            for p in (ROOT / name).rglob("*")}
