"""Aggregation: t quantiles, intervals, pairing with uniform, "% of max" and episode bands."""

import math

import numpy as np
import pytest

from mgrao_core import ConfigError, episode_band, final_utilities, make_spec, run_experiment, summarise
from mgrao_core.statistics.student import mean_ci95, t_quantile


def test_t_quantiles_are_students():
    # published two-sided 95% quantiles (to the 3 decimals of the tables), and scipy's distribution function back
    from scipy.stats import t

    assert [round(t_quantile(d), 3) for d in (1, 2, 9, 30, 100)] == [12.706, 4.303, 2.262, 2.042, 1.984]
    assert t_quantile(10**6) == pytest.approx(1.959964, abs=1e-5)
    for dof in (1, 3, 17, 250):
        assert t.cdf(t_quantile(dof), dof) == pytest.approx(0.975, abs=1e-12)
    assert t_quantile(4, confidence=0.9) == pytest.approx(2.131847, abs=1e-6)
    assert math.isnan(t_quantile(0))
    values = t_quantile(np.arange(1, 200))
    assert np.all(np.diff(values) < 0)


def test_t_quantiles_equal_scipys():
    # whole degrees of freedom come from the distribution function's series (no scipy import), others from scipy
    from scipy.special import stdtrit

    from mgrao_core.statistics.student import SERIES_DOF

    dofs = np.array([*range(1, 120), 199, 500, 999, SERIES_DOF, SERIES_DOF + 1, 10**5, 2.5, 7.25])
    for confidence in (0.5, 0.9, 0.95, 0.99, 0.999):
        ours = t_quantile(dofs, confidence)
        np.testing.assert_allclose(ours, stdtrit(dofs, 0.5 + confidence / 2), rtol=1e-12, atol=0)
    assert t_quantile(np.array([[0, 1], [2, 3]])).shape == (2, 2) and math.isnan(t_quantile(np.array([0.5]))[0])
    for dof in (1, 2, 3, 50):  # scipy's answers at the edges: inf at 1, 0 at 0, NaN outside
        assert t_quantile(dof, 1.0) == math.inf and t_quantile(dof, 0.0) == 0.0
        assert math.isnan(t_quantile(dof, 1.2)) and math.isnan(t_quantile(dof, -0.1))


def test_t_quantile_newton_stops_early(monkeypatch):
    # each Newton step is a whole series: the iteration must stop once rounding ends the rise, not run its cap
    from mgrao_core.statistics import student as stats

    calls = []
    within = stats._t_within
    monkeypatch.setattr(stats, "_t_within", lambda t, dof: calls.append(dof) or within(t, dof))
    for dof in (3, 8, 99, 999):
        for confidence in (0.95, 0.99, 0.999):
            calls.clear()
            stats._t_quantile_whole(dof, confidence)
            assert len(calls) <= 12, (dof, confidence, len(calls))


def test_a_summary_imports_no_scipy():
    # the command line's summaries (mgrao reproduce) do without scipy's 0.2 s import
    import subprocess
    import sys

    code = ("import sys; from mgrao_core.statistics.student import mean_ci95; import numpy as np; "
            "mean_ci95(np.arange(100.0)); print('scipy' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True)
    assert done.stdout.strip() == "False"


def test_mean_ci95_by_hand():
    # [1, 2, 3]: mean 2, sd 1, half width = t(2) * 1 / sqrt(3) = 4.302653 / 1.732051 = 2.484138
    mean, low, high = mean_ci95(np.array([1.0, 2.0, 3.0]))
    assert mean == 2.0
    assert low == pytest.approx(2 - 2.484138, abs=1e-6)
    assert high == pytest.approx(2 + 2.484138, abs=1e-6)


def test_mean_ci95_single_sample():
    mean, low, high = mean_ci95(np.array([4.0]))
    assert mean == 4.0 and math.isnan(low) and math.isnan(high)


def test_final_utilities_last_ten():
    utilities = np.vstack([np.arange(20.0), np.ones(20)])
    # last ten of 0..19 are 10..19: mean 14.5
    np.testing.assert_array_equal(final_utilities(utilities), [14.5, 1.0])
    np.testing.assert_array_equal(final_utilities(np.arange(4.0)), [1.5])  # fewer than ten episodes
    np.testing.assert_array_equal(final_utilities(np.arange(20.0), last=2), [18.5])


def test_summarise_pairs_by_seed():
    finals = {
        "uniform": {0: 2.0, 1: 4.0},
        "mgrao-1:1": {1: 4.0, 0: 3.0, 7: 100.0},  # other order; seed 7 has no uniform partner
        "mgrao-max": {0: 4.0, 1: 6.0},
    }
    out = summarise(finals)
    assert list(out) == ["uniform", "mgrao-1:1", "mgrao-max"]
    # 1:1: seed 0 3/2 -> +50 %, seed 1 4/4 -> 0 %: mean 25; max: +100 and +50: mean 75
    assert out["mgrao-1:1"].pct_from_uniform == pytest.approx(25.0)
    assert out["mgrao-max"].pct_from_uniform == pytest.approx(75.0)
    assert out["uniform"].pct_from_uniform == 0.0
    # pct_of_max = 100 * 25 / 75
    assert out["mgrao-1:1"].pct_of_max == pytest.approx(100 * 25 / 75)
    assert out["mgrao-max"].pct_of_max == pytest.approx(100.0)
    # CI of [50, 0]: sd 35.355, half = t(1) * 35.355 / sqrt 2 = 12.7062 * 25
    low, high = out["mgrao-1:1"].pct_ci95
    assert (low, high) == pytest.approx((25 - 12.7062047 * 25, 25 + 12.7062047 * 25))
    # the plain mean uses every seed of the label; the paired figures the two it shares with uniform
    assert out["mgrao-1:1"].n_runs == 3 and out["mgrao-1:1"].n_paired == 2 and out["mgrao-1:1"].partial
    assert out["mgrao-max"].n_paired == 2 and not out["mgrao-max"].partial
    assert out["mgrao-1:1"].final_mean == pytest.approx(107 / 3)
    assert out["uniform"].final_mean == 3.0


def test_summarise_without_uniform():
    out = summarise({"mgrao-1:1": {0: 3.0, 1: 4.0}, "mgrao-max": {0: 4.0, 1: 5.0}})
    for summary in out.values():
        assert summary.pct_from_uniform is None
        assert summary.pct_ci95 is None
        assert summary.pct_of_max is None


def test_summarise_without_max():
    out = summarise({"uniform": {0: 2.0}, "mgrao-1:1": {0: 3.0}})
    assert out["mgrao-1:1"].pct_from_uniform == pytest.approx(50.0)
    assert out["mgrao-1:1"].pct_of_max is None


def test_no_share_of_max_when_max_gained_nothing():
    # under a learning cost mgrao-max can fall below uniform: a share of its loss would flip signs (+10% "of" -20%)
    out = summarise({"uniform": {0: 2.0, 1: 4.0}, "mgrao-1:1": {0: 2.2, 1: 4.4}, "mgrao-max": {0: 1.6, 1: 3.2}})
    assert out["mgrao-1:1"].pct_from_uniform == pytest.approx(10.0)
    assert out["mgrao-max"].pct_from_uniform == pytest.approx(-20.0)
    assert out["mgrao-1:1"].pct_of_max is None and out["mgrao-max"].pct_of_max is None
    tied = summarise({"uniform": {0: 2.0}, "mgrao-1:1": {0: 2.2}, "mgrao-max": {0: 2.0}})
    assert tied["mgrao-1:1"].pct_of_max is None


def test_summary_as_dict_turns_nan_into_none():
    data = summarise({"uniform": {0: 2.0}})["uniform"].as_dict()
    assert data["ci95"] == [None, None]
    assert data["algorithm"] == "uniform"


def test_episode_band_full_resolution():
    utilities = np.array([[1.0, 2.0, 3.0, 4.0], [3.0, 4.0, 5.0, 6.0]])
    band = episode_band(utilities)
    assert band["episode"] == [0, 1, 2, 3]
    assert band["mean"] == [2.0, 3.0, 4.0, 5.0]
    # every column has sd sqrt 2: half width = 12.7062047 * sqrt 2 / sqrt 2 = 12.7062047
    np.testing.assert_allclose(band["low"], np.array([2.0, 3.0, 4.0, 5.0]) - 12.7062047)
    np.testing.assert_allclose(band["high"], np.array([2.0, 3.0, 4.0, 5.0]) + 12.7062047)


def test_episode_band_downsampling_keeps_bucket_means():
    utilities = np.array([[1.0, 2.0, 3.0, 4.0], [3.0, 4.0, 5.0, 6.0]])
    band = episode_band(utilities, points=2)
    # buckets {0, 1} and {2, 3}: means (2 + 3) / 2 and (4 + 5) / 2
    assert band["episode"] == [0, 2]
    assert band["mean"] == [2.5, 4.5]
    np.testing.assert_allclose(band["high"], [2.5 + 12.7062047, 4.5 + 12.7062047])


def test_episode_band_uneven_buckets():
    utilities = np.arange(10.0)[None, :]
    band = episode_band(utilities, points=3)
    # edges round(linspace(0, 10, 4)) = [0, 3, 7, 10]: means of 0..2, 3..6, 7..9
    assert band["episode"] == [0, 3, 7]
    assert band["mean"] == pytest.approx([1.0, 4.5, 8.0])
    assert band["low"] == band["mean"] == band["high"]  # one run: the band collapses


def test_episode_band_more_points_than_episodes():
    band = episode_band(np.ones((3, 5)), points=50)
    assert band["episode"] == [0, 1, 2, 3, 4]


def test_result_summary_matches_manual_aggregation():
    result = run_experiment(make_spec("single", seeds=[3, 8, 1], episodes=15))
    summary = result.summary()
    uniform = final_utilities(result.utilities("uniform"))
    best = final_utilities(result.utilities("mgrao-max"))
    assert summary["mgrao-max"].pct_from_uniform == pytest.approx(np.mean(100 * (best / uniform - 1)))
    assert summary["mgrao-max"].final_mean == pytest.approx(best.mean())
    bands = result.episode_bands(points=5)
    assert set(bands) == {"uniform", "mgrao-1:1", "mgrao-max"}
    assert len(bands["mgrao-max"]["mean"]) == 5


def test_summary_when_uniform_utility_is_zero():
    spec = make_spec("volatile", seeds=2, episodes=12,
                     overrides={"leave_probability": 1.0, "join_probability": 0.0})
    summary = run_experiment(spec).summary()
    assert summary["uniform"].final_mean == 0.0
    pct = summary["mgrao-max"].pct_from_uniform
    assert pct is None or math.isnan(pct)


def test_summarise_with_a_zero_uniform_seed():
    out = summarise({"uniform": {0: 0.0, 1: 2.0}, "mgrao-max": {0: 0.0, 1: 3.0}})
    assert out["mgrao-max"].n_runs == 2
    # Seed 0 has no ratio (uniform is 0); seed 1 alone gives 100 * (3 / 2 - 1).
    assert out["mgrao-max"].pct_from_uniform == pytest.approx(50.0)


def test_episode_band_rejects_zero_points():
    with pytest.raises(ConfigError) as error:
        episode_band(np.ones((2, 5)), points=0)
    assert error.value.field == "points"
