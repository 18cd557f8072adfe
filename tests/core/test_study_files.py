"""The study files shipped in ``studies/`` are valid studies (``mgrao study run FILE`` accepts them)."""

import json
from pathlib import Path

import pytest

from mgrao_core.search import make_plan

STUDIES = sorted((Path(__file__).resolve().parents[2] / "studies").glob("*.json"))


def test_there_are_study_files():
    assert STUDIES


@pytest.mark.parametrize("path", STUDIES, ids=lambda p: p.name)
def test_each_study_file_is_a_valid_study(path: Path):
    plan = make_plan(json.loads(path.read_text(encoding="utf-8")))
    assert plan.dimensions
