"""Scores that stand on their own system's seeds, whatever seeds each job ran (issue 47, items 1 and 2).

The anchors of a system and every score aggregated on it stand on one seed set, the seeds with both a uniform
and an oracle run; systems keep different numbers of seeds (ragged matrices), each system weighing the same.
rliable stays the judge on rectangular matrices (tests/core/test_comparison.py); here the ragged figures are
held to their definitions computed another way.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.stats import trim_mean

from mgrao_core.errors import ConfigError
from mgrao_core.statistics import metrics
from mgrao_core.statistics.bootstrap import generator, stratified_bootstrap
from mgrao_core.statistics.comparison import TAUS, compare, sample_efficiency
from mgrao_core.statistics.improvement import improvement_codes, improvement_of_codes
from mgrao_core.statistics.scores import World, normalisation, representatives


def _ragged(rng: np.random.Generator, counts: list[int]) -> np.ndarray:
    matrix = np.full((max(counts), len(counts)), np.nan)
    for j, n in enumerate(counts):
        matrix[:n, j] = np.round(rng.normal(0.5 + j, 0.4, n), 1)  # ties within and across tasks
    return matrix


def _columns(matrix: np.ndarray) -> list[np.ndarray]:
    return [matrix[~np.isnan(matrix[:, j]), j] for j in range(matrix.shape[1])]


@pytest.mark.parametrize("seed", range(6))
def test_ragged_metrics_weigh_every_system_the_same(seed: int) -> None:
    rng = np.random.default_rng(seed)
    counts = [int(n) for n in rng.integers(2, 30, size=int(rng.integers(1, 5)))]
    x, y = _ragged(rng, counts), _ragged(rng, [int(n) for n in rng.integers(2, 30, size=len(counts))])
    means = [c.mean() for c in _columns(x)]
    assert metrics.aggregate_mean(x) == pytest.approx(np.mean(means), abs=1e-12)
    assert metrics.aggregate_median(x) == pytest.approx(np.median(means), abs=1e-12)
    assert metrics.aggregate_optimality_gap(x) == pytest.approx(
        1 - np.mean([np.minimum(c, 1).mean() for c in _columns(x)]), abs=1e-12)
    np.testing.assert_allclose(metrics.score_distribution(x, TAUS),
                               np.mean([[np.mean(c > tau) for tau in TAUS] for c in _columns(x)], axis=0), atol=1e-12)
    by_task = [np.mean(cx[:, None] > cy[None, :]) + 0.5 * np.mean(cx[:, None] == cy[None, :])
               for cx, cy in zip(_columns(x), _columns(y), strict=True)]
    assert metrics.probability_of_improvement(x, y) == pytest.approx(np.mean(by_task), abs=1e-12)
    codes_x, codes_y, width = improvement_codes(x, y)
    assert improvement_of_codes(codes_x, codes_y, width) == pytest.approx(np.mean(by_task), abs=1e-12)


def test_the_weighted_iqm_is_scipys_trimmed_mean_where_weights_are_equal_or_replicate() -> None:
    rng = np.random.default_rng(4)
    for runs, tasks in ((9, 3), (20, 1), (7, 5)):
        square = rng.normal(size=(runs, tasks))
        padded = np.vstack([square, np.full((1, tasks), np.nan)])  # ragged in form, every task as many runs
        assert metrics.is_ragged(padded)
        assert metrics.aggregate_iqm(padded) == pytest.approx(trim_mean(square.ravel(), 0.25), abs=1e-12)
    # two systems of 2 and 6 runs: each of the first's weighs as 3 of the second's; 8 scores cut 2/8 from each end
    x = np.full((6, 2), np.nan)
    x[:2, 0], x[:, 1] = [0.1, 5.0], [0.3, 0.2, 0.9, 2.0, 0.4, 0.6]
    replicated = np.concatenate([np.repeat(x[:2, 0], 3), x[:, 1]])
    assert metrics.aggregate_iqm(x) == pytest.approx(trim_mean(replicated, 0.25), abs=1e-12)


def test_a_ragged_bootstrap_resamples_each_system_among_its_own_runs() -> None:
    rng = np.random.default_rng(5)
    x = _ragged(rng, [3, 11, 6])
    seen = []

    def record(resampled: np.ndarray) -> np.ndarray:
        seen.append(resampled)
        return metrics.aggregate_mean(resampled)

    stratified_bootstrap(record, x, repetitions=50, rng=generator(0, "x"))
    for resampled in seen[1:]:
        assert (np.isnan(resampled) == np.isnan(x)[None]).all()  # each system keeps its count
        for j, column in enumerate(_columns(x)):
            assert set(resampled[:, : len(column), j].ravel()) <= set(column)
    # the weighted IQM of counts is the IQM of the same resamples
    by_counts = stratified_bootstrap(metrics.aggregate_iqm, x, repetitions=300, rng=generator(1, "x"),
                                     of_counts=lambda m, c: metrics.aggregate_iqm_of_weighted_counts(m, c[0]))
    by_values = stratified_bootstrap(metrics.aggregate_iqm, x, repetitions=300, rng=generator(1, "x"))
    np.testing.assert_allclose([by_counts.low, by_counts.high], [by_values.low, by_values.high], atol=1e-12)


def _world(name: str, finals: dict[str, dict[int, float]], system: str | None = None) -> World:
    return World(name, system or name, 100, finals)


def _system(rng: np.random.Generator, level: float, seeds: dict[str, list[int]]) -> dict[str, dict[int, float]]:
    gains = {"uniform": 0.0, "mgrao-1:1": 0.3, "mgrao-5:1": 0.35, "mgrao-max": 0.4, "oracle": 0.8}
    base = {s: level + rng.normal(0, 0.1) for s in range(max(max(v) for v in seeds.values()) + 1)}
    return {label: {s: base[s] + gains[label] + rng.normal(0, 0.05) for s in chosen}
            for label, chosen in seeds.items()}


def test_uniform_scores_0_and_the_oracle_1_when_jobs_ran_other_seed_counts() -> None:
    # issue 47's case: single of 100 seeds beside multi of 20; before, the anchors averaged 100 seeds while the
    # matrix kept 20, and uniform's mean aggregate was not 0
    rng = np.random.default_rng(0)
    labels = ("uniform", "mgrao-1:1", "mgrao-max", "oracle")
    single = _system(rng, 1.0, {label: list(range(100)) for label in labels})
    multi = _system(rng, 3.0, {label: list(range(20)) for label in labels})
    answer = compare([_world("single", single), _world("multi", multi)], repetitions=200)
    for name, expected in (("uniform", 0.0), ("oracle", 1.0)):
        for metric in ("mean", "median"):
            assert answer["aggregate"][name][metric]["estimate"] == pytest.approx(expected, abs=1e-12)
        for system in ("single", "multi"):
            assert np.mean(answer["scores"][name][system]) == pytest.approx(expected, abs=1e-12)
    assert answer["aggregated"]["n_seeds"] == {"single": 100, "multi": 20}
    assert len(answer["scores"]["mgrao-max"]["single"]) == 100


seed_sets = st.lists(st.integers(0, 39), min_size=0, max_size=40, unique=True)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_anchors_and_scores_stand_on_one_seed_set_for_any_mix_of_seeds(data) -> None:
    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    worlds = []
    for k in range(data.draw(st.integers(1, 4))):
        seeds = {label: sorted(data.draw(seed_sets, label=f"{k}:{label}")) or [0]
                 for label in ("uniform", "mgrao-1:1", "mgrao-max", "oracle")}
        if data.draw(st.booleans(), label=f"{k}: a rule-stopped job beside"):
            seeds["mgrao-5:1"] = list(range(data.draw(st.integers(1, 40))))  # the first n seeds, as a rule stops
        worlds.append(_world(f"w{k}", _system(rng, 1.0 + k, seeds)))
    answer = compare(worlds, repetitions=20)
    aggregated = answer["aggregated"]
    for w in worlds:
        anchors = normalisation(w)
        if w.name not in aggregated["systems"]:
            continue
        assert aggregated["seeds"][w.name] == list(anchors.seeds)
        assert set(anchors.seeds) == set(w.finals["uniform"]) & set(w.finals["oracle"])
        for label, finals in w.finals.items():
            left = set(finals) - set(anchors.seeds)
            assert set(aggregated["left_out"].get(w.name, {}).get(label, {}).get("seeds", [])) == left
            if label in answer["scores"]:
                assert len(answer["scores"][label][w.name]) == len(set(finals) & set(anchors.seeds))
    if aggregated["systems"]:
        for name, expected in (("uniform", 0.0), ("oracle", 1.0)):
            for metric in ("mean", "median"):
                assert answer["aggregate"][name][metric]["estimate"] == pytest.approx(expected, abs=1e-9)


def test_two_worlds_of_one_system_are_aggregated_once_or_not_at_all() -> None:
    rng = np.random.default_rng(2)
    labels = ("uniform", "mgrao-1:1", "oracle")
    short = _world("single (episodes=50)", _system(rng, 1.0, {x: list(range(20)) for x in labels}), "single")
    long = _world("single (episodes=100)", _system(rng, 1.2, {x: list(range(20)) for x in labels}), "single")
    multi = _world("multi", _system(rng, 3.0, {x: list(range(20)) for x in labels}))
    refused = compare([short, long, multi], repetitions=50)
    assert refused["aggregate"] == {} and refused["aggregated"]["systems"] == []
    assert "single (single (episodes=50); single (episodes=100))" in refused["aggregated"]["reason"]
    assert refused["aggregated"]["worlds_of_system"] == {"single": ["single (episodes=50)", "single (episodes=100)"]}
    assert len(refused["systems"]) == 3  # each world's own figures remain
    chosen = compare([short, long, multi], repetitions=50, aggregate=["single (episodes=100)"])
    assert chosen["aggregated"]["systems"] == ["single (episodes=100)", "multi"]
    alone = compare([long, multi], repetitions=50)
    assert chosen["aggregate"] == alone["aggregate"]
    curves = sample_efficiency([World(w.name, w.system, 100, w.finals, (), {
        label: {s: np.full(3, f) for s, f in finals.items()} for label, finals in w.finals.items()})
        for w in (short, long, multi)], repetitions=20)
    assert curves["curves"] == {} and "several worlds of one system" in curves["reason"]
    for bad, message in ((["nowhere"], "not a system of this comparison"),
                         (["single (episodes=50)", "single (episodes=100)"], "are both worlds of single")):
        with pytest.raises(ConfigError) as error:
            compare([short, long, multi], repetitions=50, aggregate=bad)
        assert error.value.field == "aggregate" and message in error.value.message
    assert representatives([short, multi]) == (["single (episodes=50)", "multi"], None)
