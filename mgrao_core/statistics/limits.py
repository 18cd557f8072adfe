"""What one answer of the comparison statistics may cost: the limits and their checks (docs/statistics.md)."""

from __future__ import annotations

from collections.abc import Sequence

from mgrao_core.errors import ConfigError
from mgrao_core.statistics.scores import World

MAX_CONFIGURATIONS = 40
"""Configurations of one world at most: the head-to-head tests and P(X > Y) grow with their pairs (780 here)."""
MAX_PAIRED_DIFFERENCES = 5_000_000
"""Paired differences the head-to-head tests of one answer rank at most (pairs x their shared seeds, bounded
from above by each world's pairs x its most seeds): about 5,000 tests of 1,000 seeds, some seconds."""
MAX_RESAMPLED = 500_000_000
"""Resampled scores of one answer's bootstraps at most (repetitions x the scores each repetition draws): about 20 s
on one core; more is refused, naming the repetitions that fit."""


def check_size(worlds: Sequence[World]) -> None:
    """Refuse (naming ``jobs``) what the statistics cannot bound.

    A world with more than :data:`MAX_CONFIGURATIONS` configurations, or worlds whose paired tests would rank
    more than :data:`MAX_PAIRED_DIFFERENCES` differences.
    """
    for w in worlds:
        if len(w.finals) > MAX_CONFIGURATIONS:
            raise ConfigError("jobs", f"{w.name} has {len(w.finals)} configurations among the jobs: the statistics "
                                      f"compare at most {MAX_CONFIGURATIONS} per system (compare fewer jobs)")
    differences = sum(len(w.finals) * (len(w.finals) - 1) // 2 * max((len(f) for f in w.finals.values()), default=0)
                      for w in worlds)
    if differences > MAX_PAIRED_DIFFERENCES:
        raise ConfigError("jobs", f"the paired tests of these jobs would rank up to {differences:,} differences, over "
                                  f"the limit of {MAX_PAIRED_DIFFERENCES:,} per answer (compare fewer jobs, "
                                  "configurations or seeds)")


def check_work(repetitions: int, per_repetition: int) -> None:
    """Refuse (naming ``reps``) bootstraps that would resample more than :data:`MAX_RESAMPLED` scores."""
    if repetitions * per_repetition > MAX_RESAMPLED:
        fit = max(1, MAX_RESAMPLED // max(1, per_repetition))
        raise ConfigError("reps", f"{repetitions:,} repetitions x {per_repetition:,} scores each exceeds the limit of "
                                  f"{MAX_RESAMPLED:,} resampled scores per answer: use reps <= {fit:,}")
