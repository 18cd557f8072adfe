"""A configuration's summary in its world: final utility, % from uniform, % of max (docs/model.md, "What a result is").

Per configuration: the mean utility of the last :data:`FINAL_EPISODES` episodes of each run,
averaged over seeds, with a 95% t-interval; "% from uniform" paired seed by seed with the uniform
run of the same seed (common random numbers), over the seeds both have (``n_paired``); "% of max",
the share of ``mgrao-max``'s gain over uniform on the seeds all three share (the paper's column,
e.g. 23.4 / 28.0 = 83.6% for single 1:1).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass

import numpy as np

from mgrao_core.statistics.student import mean_ci95

FINAL_EPISODES = 10
BASELINE = "uniform"
REFERENCE = "mgrao-max"


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
