"""Learning curves over seeds: each episode's mean with a 95% t-band, one run at a time."""

from __future__ import annotations

import math

import numpy as np

from mgrao_core.errors import ConfigError
from mgrao_core.statistics.student import t_quantile


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
            spread = np.sqrt(np.maximum(self._m2, 0.0) / (self.runs - 1))
            half = t_quantile(self.runs - 1) * spread / math.sqrt(self.runs)
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
