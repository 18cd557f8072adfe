"""A newcomer's first hour, round 4 (issue 43): what the command line and the reports say."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner

from mgrao_cli.main import cli
from mgrao_core.statistics.comparison import compare
from mgrao_core.statistics.report import deciding_digits, latex, table
from tests.core.test_comparison import _paper_like

ROOT = Path(__file__).resolve().parents[2]


def test_the_latex_caption_gives_each_world_a_sentence_and_a_line_of_its_own() -> None:
    """Issue 43, item 13: the caption glued the worlds together ("...seeds 0-29 large: 100 episodes...")."""
    answer = compare(_paper_like(), repetitions=50)
    tex = latex(answer)
    caption = tex[tex.index("\\caption{") + len("\\caption{"): tex.index("}\n\\begin{tabular}")]
    lines = caption.splitlines()
    for world in ("single", "large", "multi"):
        own = [line for line in lines if line.startswith(f"{world}: ")]
        assert own == [f"{world}: 100 episodes, seeds 0-29."], lines
    assert all(line.rstrip().endswith(".") for line in lines), lines  # every line a sentence
    assert not re.search(r"seeds [0-9-]+ \w+: ", caption), caption  # no world glued to the next


def test_compare_table_reads_its_names_from_the_left() -> None:
    """Issue 43, item 13: the configuration column was right-aligned under its header."""
    text = table(compare(_paper_like(), repetitions=50))
    header, _rule, *rows = text.splitlines()
    start = header.index("configuration")
    for row in rows[:4]:
        assert row[start] != " ", (header, row)  # each configuration starts under its header
    assert any(row[start:].startswith("uniform ") for row in rows[:4]), rows[:4]


def test_run_help_prints_percent_once() -> None:
    """Issue 43, item 13: ``mgrao run --help`` printed "95%%" (fixed before this round; kept)."""
    result = CliRunner().invoke(cli, ["run", "--help"], terminal_width=200)
    assert result.exit_code == 0, result.output
    assert "95% interval" in result.output and "%%" not in result.output


def test_the_readme_says_where_compare_finds_its_service() -> None:
    """Issue 43, item 13: the README's compare examples never showed ``--url``; compare asks port 8000."""
    readme = (ROOT / "README.md").read_text()
    assert re.search(r"^\s+mgrao compare \S+ .*--url http", readme, re.M), "no compare example with --url"
    assert "http://127.0.0.1:8000" in readme and "MGRAO_URL" in readme


def test_one_rounding_rule_shows_the_digit_that_decides_whether_the_paper_lies_in_the_interval() -> None:
    """Issue 43, item 12: the command line's rule is the dashboard's (the cases of tests/frontend/js/paperdata.test.mjs,
    decidingDigits)."""
    assert deciding_digits([23.31, 27.99], 28.0) == 2  # outside by 0.01: +27.99% against +28.00%
    assert deciding_digits([23.31, 27.2], 28.0) == 1  # plainly outside
    assert deciding_digits([23.31, 28.04], 28.0) == 1  # within, and reads within
    assert deciding_digits([23.31, 27.9999], 28.0) == 4  # at most four
    assert deciding_digits(None, 28.0) == deciding_digits([1.0, 2.0], None) == 1
