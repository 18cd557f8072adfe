"""The paper's four tables, ours beside the paper's."""

import pytest

from mgrao_core import PRESETS
from mgrao_core.reproduction import reproduce, reproduction_table


@pytest.fixture(scope="module")
def table():
    return reproduction_table(reproduce(seeds=3, episodes=20))


def test_every_system_and_algorithm(table):
    assert set(table["systems"]) == {"single", "multi", "volatile", "large"}
    for name, rows in table["systems"].items():
        assert list(rows) == list(PRESETS[name].algorithms)
        for label, row in rows.items():
            for key in ("pct_from_uniform", "ci95", "pct_of_max", "paper_pct_from_uniform",
                        "paper_pct_of_max", "final_mean", "final_ci95"):
                assert key in row, (name, label, key)
            assert row["paper_pct_from_uniform"] == PRESETS[name].paper_pct_from_uniform.get(label)
            assert row["paper_pct_of_max"] == PRESETS[name].paper_pct_of_max.get(label)
            assert len(row["ci95"]) == 2 and row["ci95"][0] <= row["pct_from_uniform"] <= row["ci95"][1]


def test_rows_agree_with_each_other(table):
    single = table["systems"]["single"]
    assert single["uniform"]["pct_from_uniform"] == 0.0
    assert single["uniform"]["paper_pct_from_uniform"] is None
    assert single["mgrao-max"]["pct_of_max"] == pytest.approx(100.0)
    expected = 100 * single["mgrao-1:1"]["pct_from_uniform"] / single["mgrao-max"]["pct_from_uniform"]
    assert single["mgrao-1:1"]["pct_of_max"] == pytest.approx(expected)
    assert table["systems"]["large"]["mgrao-25:1"]["paper_pct_from_uniform"] == 19.5


def test_paper_tables_as_printed(table):
    assert table["systems"]["single"]["mgrao-1:1"]["paper_pct_of_max"] == 83.7
    assert table["systems"]["large"]["mgrao-max"]["paper_pct_of_max"] == 100.0
    assert table["systems"]["single"]["uniform"]["paper_pct_of_max"] is None
    for preset in PRESETS.values():
        assert set(preset.paper_pct_of_max) == set(preset.paper_pct_from_uniform)


def test_reproduce_runs_the_papers_four_systems_not_every_preset():
    import inspect

    assert inspect.signature(reproduce).parameters["systems"].default == ("single", "multi", "volatile", "large")


def test_reproduce_subset_with_progress_and_overrides():
    seen = []
    results = reproduce(seeds=2, episodes=5, overrides={"temperature": 1.0}, systems=("single", "multi"),
                        on_progress=lambda name, f: seen.append((name, f)))
    assert list(results) == ["single", "multi"]
    assert results["multi"].spec.params.temperature == 1.0
    assert seen == [("single", 1.0), ("multi", 1.0)]
