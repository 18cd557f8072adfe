"""The statistics of results and comparisons, one concern per module (docs/statistics.md).

* :mod:`~mgrao_core.statistics.student`: Student's t quantile and the mean's interval;
* :mod:`~mgrao_core.statistics.summary`: a configuration's summary in its world (final utility, % from uniform,
  % of max); :mod:`~mgrao_core.statistics.bands`: learning curves with their bands;
* :mod:`~mgrao_core.statistics.pairing`: which runs pair (worlds and configurations);
* :mod:`~mgrao_core.statistics.scores`: oracle-normalised scores and their matrices;
* :mod:`~mgrao_core.statistics.metrics`: the aggregates over a score matrix (as ``rliable.metrics``);
* :mod:`~mgrao_core.statistics.bootstrap`: the stratified bootstrap every interval goes through (as
  ``rliable.library``); :mod:`~mgrao_core.statistics.improvement`: P(X > Y) by counting;
* :mod:`~mgrao_core.statistics.paired_tests`: paired differences, Wilcoxon's test and Holm's adjustment;
* :mod:`~mgrao_core.statistics.limits`: what one answer may cost;
* :mod:`~mgrao_core.statistics.comparison`: one comparison's answer from all of these;
  :mod:`~mgrao_core.statistics.report`: that answer as a table, CSV or LaTeX;
* :mod:`~mgrao_core.statistics.sequential`: seeds until decided (stopping rules), imported on its own (it runs
  experiments).
"""

from mgrao_core.statistics.bands import EpisodeStats, episode_band
from mgrao_core.statistics.student import CONFIDENCE, mean_ci95, t_quantile
from mgrao_core.statistics.summary import (
    BASELINE,
    FINAL_EPISODES,
    REFERENCE,
    ConfigSummary,
    final_utilities,
    paired_pct_from_uniform,
    summarise,
)

__all__ = [
    "BASELINE",
    "CONFIDENCE",
    "FINAL_EPISODES",
    "REFERENCE",
    "ConfigSummary",
    "EpisodeStats",
    "episode_band",
    "final_utilities",
    "mean_ci95",
    "paired_pct_from_uniform",
    "summarise",
    "t_quantile",
]
