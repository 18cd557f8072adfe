"""Aggregation of episode utilities: what a result is, docs/model.md ("What a result is").

Per configuration: the mean utility of the last :data:`FINAL_EPISODES` episodes of each run,
averaged over seeds, with a 95% t-interval; "% from uniform" paired seed by seed with the uniform
run of the same seed (common random numbers); "% of max", the share of ``mgrao-max``'s gain over
uniform (the paper's column, e.g. 23.4 / 28.0 = 83.6% for single 1:1).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass

import numpy as np

from mgrao_core.errors import ConfigError

FINAL_EPISODES = 10
BASELINE = "uniform"
REFERENCE = "mgrao-max"

# Two-sided 95% quantiles of Student's t for 1..30 degrees of freedom.
_T95 = (
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
    2.201, 2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
    2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
)


def t95(dof: int) -> float:
    """Two-sided 95% Student-t quantile (table to 30 dof, Cornish-Fisher expansion beyond)."""
    if dof < 1:
        return math.nan
    if dof <= len(_T95):
        return _T95[dof - 1]
    z = 1.959963984540054
    return z + (z**3 + z) / (4 * dof) + (5 * z**5 + 16 * z**3 + 3 * z) / (96 * dof**2)


def mean_ci95(samples: np.ndarray) -> tuple[float, float, float]:
    """Mean and 95% t-interval ``(mean, low, high)``; the interval is NaN for one sample."""
    samples = np.asarray(samples, dtype=float)
    mean = float(samples.mean())
    if samples.size < 2:
        return mean, math.nan, math.nan
    half = t95(samples.size - 1) * float(samples.std(ddof=1)) / math.sqrt(samples.size)
    return mean, mean - half, mean + half


def final_utilities(utilities: np.ndarray, last: int = FINAL_EPISODES) -> np.ndarray:
    """Mean of the last ``last`` episodes of each run; ``utilities`` is ``(runs, episodes)``."""
    utilities = np.atleast_2d(np.asarray(utilities, dtype=float))
    return utilities[:, -min(last, utilities.shape[1]) :].mean(axis=1)


@dataclass(frozen=True)
class ConfigSummary:
    """The summary of one configuration (one algorithm of one system and parameter set)."""

    algorithm: str
    n_runs: int
    final_mean: float
    ci95: tuple[float, float]
    pct_from_uniform: float | None
    pct_ci95: tuple[float, float] | None
    pct_of_max: float | None

    def as_dict(self) -> dict:
        """JSON-ready data; NaN becomes None."""
        def clean(value):
            if isinstance(value, float) and math.isnan(value):
                return None
            if isinstance(value, tuple):
                return [clean(v) for v in value]
            return value

        return {k: clean(v) for k, v in asdict(self).items()}


def paired_pct_from_uniform(by_seed: Mapping[int, float], baseline: Mapping[int, float] | None) -> dict[int, float]:
    """Each seed's % from uniform: ``100 (final / uniform's final of the same seed - 1)``, in seed order.

    Only the seeds both have where uniform's final utility is positive (:func:`summarise` averages
    these); empty without a baseline.
    """
    common = sorted(s for s in set(by_seed) & set(baseline) if baseline[s] > 0) if baseline else []
    return {s: 100.0 * (by_seed[s] / baseline[s] - 1.0) for s in common}


def summarise(finals: Mapping[str, Mapping[int, float]]) -> dict[str, ConfigSummary]:
    """Summaries per configuration from each run's final utility.

    Args:
        finals: configuration label -> seed -> final utility (see :func:`final_utilities`).
            "% from uniform" pairs each seed with the ``uniform`` run of the same seed and uses
            the seeds both have where uniform's utility is positive (a world where every parent
            is absent has no ratio); it is None when no seed qualifies.

    Returns:
        Label -> :class:`ConfigSummary`, in the order of ``finals``.
    """
    baseline = finals.get(BASELINE)
    pct: dict[str, tuple[float, float, float] | None] = {}
    for label, by_seed in finals.items():
        paired = paired_pct_from_uniform(by_seed, baseline)
        pct[label] = mean_ci95(np.array(list(paired.values()))) if paired else None
    reference = pct.get(REFERENCE)
    summaries = {}
    for label, by_seed in finals.items():
        mean, low, high = mean_ci95(np.array(list(by_seed.values())))
        own = pct[label]
        share = None
        if own is not None and reference is not None and reference[0] != 0:
            share = 100.0 * own[0] / reference[0]
        summaries[label] = ConfigSummary(
            algorithm=label,
            n_runs=len(by_seed),
            final_mean=mean,
            ci95=(low, high),
            pct_from_uniform=None if own is None else own[0],
            pct_ci95=None if own is None else (own[1], own[2]),
            pct_of_max=share,
        )
    return summaries


class EpisodeStats:
    """Per-episode mean and spread over runs, accumulated one run at a time (Welford's method).

    Memory is O(episodes) whatever the number of runs, so stored results can be aggregated as
    they are read; :meth:`band` gives what :func:`episode_band` gives for the stacked runs.
    """

    def __init__(self, episodes: int) -> None:
        self.runs = 0
        self.mean = np.zeros(episodes)
        self._m2 = np.zeros(episodes)

    def add(self, utilities: np.ndarray) -> None:
        """Account one run's ``(episodes,)`` utilities."""
        utilities = np.asarray(utilities, dtype=float)
        self.runs += 1
        with np.errstate(invalid="ignore"):  # a stored inf or NaN makes that episode's figures NaN
            delta = utilities - self.mean
            self.mean += delta / self.runs
            self._m2 += delta * (utilities - self.mean)

    def band(self, points: int | None = None) -> dict[str, list[float]]:
        """Mean with a 95% t-band per episode, optionally averaged into ``points`` buckets.

        Returns:
            ``{"episode": [...], "mean": [...], "low": [...], "high": [...]}``; ``episode`` is the
            bucket's first episode (0-based). With one run the band collapses onto the mean.
        """
        return {key: values.tolist() for key, values in self.band_arrays(points).items()}

    def band_arrays(self, points: int | None = None) -> dict[str, np.ndarray]:
        """:meth:`band` as numpy arrays (for serialising without a Python object per value)."""
        if points is not None and points < 1:
            raise ConfigError("points", f"must be at least 1 (got {points})")
        episodes = self.mean.shape[0]
        mean = self.mean
        if self.runs > 1:
            half = t95(self.runs - 1) * np.sqrt(np.maximum(self._m2, 0.0) / (self.runs - 1)) / math.sqrt(self.runs)
        else:
            half = np.zeros(episodes)
        starts = np.arange(episodes)
        if points is not None and points < episodes:
            edges = np.linspace(0, episodes, points + 1).round().astype(int)
            starts = edges[:-1]
            mean = np.add.reduceat(mean, starts) / np.diff(edges)
            half = np.add.reduceat(half, starts) / np.diff(edges)
        return {"episode": starts, "mean": mean, "low": mean - half, "high": mean + half}


def episode_band(utilities: np.ndarray, points: int | None = None) -> dict[str, list[float]]:
    """Mean over runs per episode with a 95% band, optionally averaged into ``points`` buckets.

    Args:
        utilities: ``(runs, episodes)``.
        points: at most this many points (equal buckets of consecutive episodes); all when None.

    Returns:
        ``{"episode": [...], "mean": [...], "low": [...], "high": [...]}``; ``episode`` is the
        bucket's first episode (0-based). With one run the band collapses onto the mean.
    """
    utilities = np.atleast_2d(np.asarray(utilities, dtype=float))
    stats = EpisodeStats(utilities.shape[1])
    for row in utilities:
        stats.add(row)
    return stats.band(points)
