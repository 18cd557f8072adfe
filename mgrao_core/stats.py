"""Aggregation of episode utilities: what a result is, docs/model.md ("What a result is"), docs/statistics.md.

Per configuration: the mean utility of the last :data:`FINAL_EPISODES` episodes of each run,
averaged over seeds, with a 95% t-interval; "% from uniform" paired seed by seed with the uniform
run of the same seed (common random numbers), over the seeds both have (``n_paired``); "% of max",
the share of ``mgrao-max``'s gain over uniform on the seeds all three share (the paper's column,
e.g. 23.4 / 28.0 = 83.6% for single 1:1). The t quantiles of whole degrees of freedom are computed
here exactly; scipy (its tests, and any other quantile) is imported on first use, so that importing
the core (a worker's start) does not load it.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from statistics import NormalDist

import numpy as np

from mgrao_core.errors import ConfigError

FINAL_EPISODES = 10
BASELINE = "uniform"
REFERENCE = "mgrao-max"
CONFIDENCE = 0.95
"""The level of every interval the core gives (two-sided)."""


SERIES_DOF = 1000
"""Most degrees of freedom :func:`t_quantile` solves from the series (its ``dof / 2`` terms' rounding
grows with them: 3e-13 relative at 1,000, 3e-11 at 100,000); beyond, scipy's ``stdtrit``."""


def _t_within(t: float, dof: int) -> float:
    """``P(-t < T < t)`` for Student's t with a whole number ``dof`` of degrees of freedom, exactly.

    Abramowitz and Stegun 26.7.3 (odd ``dof``) and 26.7.4 (even): with ``theta = atan(t / sqrt(dof))``,
    a finite series in ``cos(theta)`` of ``dof / 2`` terms.
    """
    theta = math.atan(t / math.sqrt(dof))
    c2 = math.cos(theta) ** 2
    if dof % 2:  # (2/pi) (theta + sin cos (1 + 2/3 cos^2 + 2*4/(3*5) cos^4 + ...)), the series up to cos^(dof-3)
        ratios = np.arange(2, dof - 1, 2, dtype=float) / np.arange(3, dof, 2, dtype=float) * c2
        series = 1.0 + float(np.cumprod(ratios).sum())
        return 2.0 / math.pi * (theta + math.sin(theta) * math.cos(theta) * series)
    ratios = np.arange(1, dof - 1, 2, dtype=float) / np.arange(2, dof, 2, dtype=float) * c2  # 1 + 1/2 cos^2 + ...
    return math.sin(theta) * (1.0 + float(np.cumprod(ratios).sum()))


def _t_quantile_whole(dof: int, confidence: float) -> float:
    """The ``t`` with ``P(-t < T < t) = confidence``, by Newton's method on :func:`_t_within`.

    That function is concave for ``t > 0``, so every iterate is below the root and rises to it (the
    start, the normal quantile, is below it already: t's tails are heavier), until rounding makes a
    step no longer positive (within about 1e-13 of the root): there it stops.
    """
    if not 0.0 < confidence < 1.0:
        return math.inf if confidence == 1.0 else 0.0 if confidence == 0.0 else math.nan
    if dof == 1:
        return math.tan(math.pi * confidence / 2)
    if dof == 2:
        return confidence * math.sqrt(2.0 / (1.0 - confidence * confidence))
    log_density = math.lgamma((dof + 1) / 2) - math.lgamma(dof / 2) - 0.5 * math.log(dof * math.pi)
    t = NormalDist().inv_cdf(0.5 + confidence / 2)
    for _ in range(100):
        density = math.exp(log_density - (dof + 1) / 2 * math.log1p(t * t / dof))
        step = (confidence - _t_within(t, dof)) / (2.0 * density)
        t += step
        if step <= 4 * sys.float_info.epsilon * t:
            break
    return t


def t_quantile(dof: int | np.ndarray, confidence: float = CONFIDENCE) -> float | np.ndarray:
    """The two-sided ``confidence`` quantile of Student's t with ``dof`` degrees of freedom (NaN below 1).

    ``t_quantile(9)`` is 2.2622. Whole degrees of freedom up to :data:`SERIES_DOF` (every interval
    here is on ``n - 1``) are solved from the distribution function's finite series (:func:`_t_within`),
    within 1e-12 of scipy's ``stdtrit`` (tests/core/test_stats.py); others go to scipy, whose 0.2 s
    import a command's summaries (``mgrao reproduce``) thus do without.
    """
    dofs = np.asarray(dof, dtype=float)
    flat = dofs.ravel()
    value = np.full(flat.shape, math.nan)
    for i, d in enumerate(flat):
        if 1 <= d <= SERIES_DOF and d == math.floor(d):
            value[i] = _t_quantile_whole(int(d), confidence)
        elif d >= 1:
            from scipy.special import stdtrit  # only for a fractional (or huge) number of degrees of freedom

            value[i] = stdtrit(d, 0.5 + confidence / 2)
    return float(value[0]) if dofs.ndim == 0 else value.reshape(dofs.shape)


def mean_ci95(samples: np.ndarray) -> tuple[float, float, float]:
    """Mean and 95% t-interval ``(mean, low, high)``; the interval is NaN for one sample."""
    samples = np.asarray(samples, dtype=float)
    mean = float(samples.mean())
    if samples.size < 2:
        return mean, math.nan, math.nan
    half = t_quantile(samples.size - 1) * float(samples.std(ddof=1)) / math.sqrt(samples.size)
    return mean, mean - half, mean + half


def final_utilities(utilities: np.ndarray, last: int = FINAL_EPISODES) -> np.ndarray:
    """Mean of the last ``last`` episodes of each run; ``utilities`` is ``(runs, episodes)``."""
    utilities = np.atleast_2d(np.asarray(utilities, dtype=float))
    return utilities[:, -min(last, utilities.shape[1]) :].mean(axis=1)


@dataclass(frozen=True)
class ConfigSummary:
    """The summary of one configuration (one algorithm of one system and parameter set).

    ``n_runs`` seeds make ``final_mean`` and ``ci95``; ``n_paired`` of them, those uniform also ran (with a
    positive final utility), make ``pct_from_uniform`` and ``pct_ci95``; ``pct_of_max`` is taken on the
    ``n_paired_max`` seeds that uniform and ``mgrao-max`` also ran.
    """

    algorithm: str
    n_runs: int
    final_mean: float
    ci95: tuple[float, float]
    pct_from_uniform: float | None
    pct_ci95: tuple[float, float] | None
    pct_of_max: float | None
    n_paired: int = 0
    n_paired_max: int = 0

    @property
    def partial(self) -> bool:
        """Whether only some of its seeds pair with the baseline (its % from uniform stands on fewer seeds)."""
        return 0 < self.n_paired < self.n_runs

    def as_dict(self) -> dict:
        """JSON-ready data with :attr:`partial`; NaN becomes None."""
        def clean(value):
            if isinstance(value, float) and math.isnan(value):
                return None
            if isinstance(value, tuple):
                return [clean(v) for v in value]
            return value

        return {k: clean(v) for k, v in asdict(self).items()} | {"partial": self.partial}


def paired_pct_from_uniform(by_seed: Mapping[int, float], baseline: Mapping[int, float] | None) -> dict[int, float]:
    """Each seed's % from uniform: ``100 (final / uniform's final of the same seed - 1)``, in seed order.

    Only the seeds both have where uniform's final utility is positive (:func:`summarise` averages
    these); empty without a baseline.
    """
    common = sorted(s for s in set(by_seed) & set(baseline) if baseline[s] > 0) if baseline else []
    return {s: 100.0 * (by_seed[s] / baseline[s] - 1.0) for s in common}


def summarise(finals: Mapping[str, Mapping[int, float]], baseline: str = BASELINE,
              reference: str = REFERENCE) -> dict[str, ConfigSummary]:
    """Summaries per configuration from each run's final utility.

    Args:
        finals: configuration label -> seed -> final utility (see :func:`final_utilities`), the
            configurations of one world.
        baseline: the label "% from uniform" pairs with: each seed with the baseline's run of the same
            seed, over the seeds both have where the baseline's utility is positive (a world where every
            parent is absent has no ratio); None when no seed qualifies.
        reference: the label "% of max" divides by: both gains averaged over the seeds the configuration,
            the baseline and the reference all have; None where the reference gained nothing over the
            baseline (under a learning cost ``mgrao-max`` can fall below uniform: a share of a loss means nothing).

    Returns:
        Label -> :class:`ConfigSummary`, in the order of ``finals``.
    """
    base = finals.get(baseline)
    paired = {label: paired_pct_from_uniform(by_seed, base) for label, by_seed in finals.items()}
    of_reference = paired.get(reference, {})
    summaries = {}
    for label, by_seed in finals.items():
        mean, low, high = mean_ci95(np.array(list(by_seed.values())))
        own = paired[label]
        pct = mean_ci95(np.array(list(own.values()))) if own else None
        shared = [s for s in own if s in of_reference]
        share = None
        if shared:
            gain = float(np.mean([of_reference[s] for s in shared]))
            if gain > 0:
                share = 100.0 * float(np.mean([own[s] for s in shared])) / gain
        summaries[label] = ConfigSummary(
            algorithm=label,
            n_runs=len(by_seed),
            final_mean=mean,
            ci95=(low, high),
            pct_from_uniform=None if pct is None else pct[0],
            pct_ci95=None if pct is None else (pct[1], pct[2]),
            pct_of_max=share,
            n_paired=len(own),
            n_paired_max=len(shared),
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
