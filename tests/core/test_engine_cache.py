"""The kernel's cache stamp follows every compiled source: the engine, the quality models and the algorithms.

These build small package trees and hash them; :mod:`tests.core.test_engine_build` checks on a copy of the
real package that an edit of such a file recompiles the kernel.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import mgrao_core
from mgrao_core.engine.cache import PACKAGE_DIR, compiled_sources, sources_digest


def _tree(root: Path, *files: str) -> Path:
    for name in files:
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(f"# {name}\n")
    return root


def test_the_compiled_sources_are_the_engine_the_quality_models_and_the_algorithms(tmp_path: Path) -> None:
    package = _tree(tmp_path, "engine/__init__.py", "engine/kernel.py", "quality.py", "algorithms/__init__.py",
                    "algorithms/mgrao.py", "algorithms/bandit/learner.py", "runner.py", "params.py",
                    "engine/notes.txt")
    names = [path.relative_to(package).as_posix() for path in compiled_sources(package)]
    assert names == ["algorithms/__init__.py", "algorithms/bandit/learner.py", "algorithms/mgrao.py",
                     "engine/__init__.py", "engine/kernel.py", "quality.py"]


def test_a_single_algorithms_module_counts_too(tmp_path: Path) -> None:
    package = _tree(tmp_path, "engine/kernel.py", "quality.py", "algorithms.py")
    assert [path.name for path in compiled_sources(package)] == ["algorithms.py", "kernel.py", "quality.py"]


def test_the_installed_package_hashes_its_quality_models() -> None:
    assert PACKAGE_DIR == Path(mgrao_core.__file__).resolve().parent
    names = {path.relative_to(PACKAGE_DIR).as_posix() for path in compiled_sources()}
    assert {"quality.py", "engine/kernel.py", "engine/environment.py", "algorithms/mgrao/compiled.py"} <= names


@pytest.mark.parametrize("edited", ["engine/kernel.py", "quality.py", "algorithms/mgrao.py",
                                    "algorithms/bandit/learner.py"])
def test_editing_any_compiled_source_changes_the_digest(tmp_path: Path, edited: str) -> None:
    package = _tree(tmp_path, "engine/kernel.py", "quality.py", "algorithms/mgrao.py", "algorithms/bandit/learner.py")
    before = sources_digest(package)
    assert sources_digest(package) == before
    with (package / edited).open("a") as source:
        source.write("# edited\n")
    assert sources_digest(package) != before


def test_adding_an_algorithm_module_or_renaming_one_changes_the_digest(tmp_path: Path) -> None:
    package = _tree(tmp_path, "engine/kernel.py", "quality.py", "algorithms/mgrao.py")
    before = sources_digest(package)
    _tree(package, "algorithms/bandit.py")
    added = sources_digest(package)
    assert added != before
    (package / "algorithms" / "bandit.py").rename(package / "algorithms" / "bandits.py")
    assert sources_digest(package) not in (before, added)


def test_editing_other_modules_keeps_the_digest(tmp_path: Path) -> None:
    package = _tree(tmp_path, "engine/kernel.py", "quality.py", "runner.py")
    before = sources_digest(package)
    (package / "runner.py").write_text("# edited\n")
    assert sources_digest(package) == before
