"""The suite's set-up byte-compiles the project (tests/conftest.py): every package's modules, read by every process."""

from __future__ import annotations

import importlib.util
from pathlib import Path

from tests.conftest import byte_compile_the_project
from tests.support.project import ROOT, packages


def test_every_module_of_the_projects_packages_and_the_tests_helpers_is_byte_compiled() -> None:
    places = [ROOT / name for name in packages()] + [ROOT / "tests" / "support"]
    sources = [path for place in places if place.is_dir() for path in place.rglob("*.py")]
    assert any(p.parts[-2:] == ("engine", "kernel.py") for p in sources) and len(sources) > 100, len(sources)
    compiled = {p: Path(importlib.util.cache_from_source(str(p))) for p in sources}
    for pyc in compiled.values():  # the session's own set-up made them: without them Python reads the sources
        pyc.unlink(missing_ok=True)
    byte_compile_the_project()
    missing = [str(p.relative_to(ROOT)) for p, pyc in compiled.items()
               if not pyc.exists() or pyc.stat().st_mtime < p.stat().st_mtime]
    assert not missing, missing
