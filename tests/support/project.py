"""The project as pyproject.toml declares it: the packages it installs."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def packages() -> list[str]:
    """The top-level packages pyproject.toml installs (``[tool.setuptools.packages.find] include``, without ``*``)."""
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["setuptools"]
    return sorted({pattern.rstrip("*") for pattern in setuptools["packages"]["find"]["include"]})
