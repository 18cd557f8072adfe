"""The backend's layers import only downwards: api over services and execution, both over store.

``backend/processes.py`` (which connects the job runners to the studies) and the API may import any
layer; ``errors``, ``settings`` and ``wakeup`` are read by every layer and import none.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

BACKEND = Path(__file__).resolve().parents[2] / "backend"
# What each layer may import of the backend's own packages.
ALLOWED = {
    "store": {"store"},
    "execution": {"execution", "store"},
    "services": {"services", "store"},
    "api": {"api", "services", "execution", "store"},
}


def _backend_imports(path: Path) -> list[tuple[int, str]]:
    """``(line, layer)`` of every import of a ``backend.<layer>`` module in ``path``, type-only ones included."""
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names = [node.module or ""] if isinstance(node, ast.ImportFrom) else (
            [alias.name for alias in node.names] if isinstance(node, ast.Import) else [])
        for name in names:
            parts = name.split(".")
            if len(parts) >= 2 and parts[0] == "backend" and parts[1] in ALLOWED:
                found.append((node.lineno, parts[1]))
    return found


@pytest.mark.parametrize("layer", sorted(ALLOWED))
def test_each_layer_imports_only_the_layers_below_it(layer: str) -> None:
    wrong = [f"backend/{path.relative_to(BACKEND).as_posix()}:{line} imports backend.{other}"
             for path in sorted((BACKEND / layer).rglob("*.py"))
             for line, other in _backend_imports(path) if other not in ALLOWED[layer]]
    assert not wrong, "\n".join(wrong)


def test_the_shared_modules_import_no_layer() -> None:
    for name in ("errors.py", "settings.py", "wakeup.py"):
        assert _backend_imports(BACKEND / name) == [], name
