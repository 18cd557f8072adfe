"""MG-RAO core: the simulated systems and algorithms of Creech et al. (2021), batched and seeded.

A pure library: numpy and numba, no I/O, no web, no database. :mod:`mgrao_core.env` (the optional
``env`` extra: PettingZoo and Gymnasium) offers the simulated world to learners of one's own.

    >>> from mgrao_core import make_spec, run_experiment
    >>> result = run_experiment(make_spec("single", seeds=5, episodes=100))
    >>> result.summary()["mgrao-max"].pct_from_uniform  # doctest: +SKIP
"""

from mgrao_core.algorithms import Algorithm, divisors, parent_groups, parse_algorithm
from mgrao_core.budget import MAX_CHUNK_BYTES, MAX_RESULT_BYTES, plan_chunks
from mgrao_core.errors import Cancelled, ConfigError, MgraoError, NumericalError, WorkLimitError
from mgrao_core.params import PARAMETERS, Parameter, SystemParams, complete_params, identity_params, make_params
from mgrao_core.presets import PAPER_SYSTEMS, PRESETS, Preset, get_preset
from mgrao_core.results import ExperimentResult, Run, TaskCounts
from mgrao_core.spec import (
    MAX_ALGORITHMS,
    MAX_EPISODES,
    MAX_GROUP_UPDATES,
    MAX_SEEDS,
    MAX_WORK,
    WORK_FACTORS,
    ExperimentSpec,
    make_spec,
    spec_from_dict,
)
from mgrao_core.statistics.bands import EpisodeStats, episode_band
from mgrao_core.statistics.summary import (
    FINAL_EPISODES,
    ConfigSummary,
    final_utilities,
    paired_pct_from_uniform,
    summarise,
)

__version__ = "0.1.0"

_COMPILED = {"run_chunk", "run_experiment"}
"""Names that need the compiled engine: imported on first use, so that importing the package (the
schema, presets and limits, as ``mgrao --help`` and the web layer's validation need) loads no numba."""


def __getattr__(name: str):
    if name in _COMPILED:
        from mgrao_core import runner

        return getattr(runner, name)
    raise AttributeError(f"module 'mgrao_core' has no attribute {name!r}")

__all__ = [
    "FINAL_EPISODES",
    "MAX_ALGORITHMS",
    "MAX_CHUNK_BYTES",
    "MAX_EPISODES",
    "MAX_GROUP_UPDATES",
    "MAX_RESULT_BYTES",
    "MAX_SEEDS",
    "MAX_WORK",
    "PARAMETERS",
    "PAPER_SYSTEMS",
    "PRESETS",
    "WORK_FACTORS",
    "Algorithm",
    "Cancelled",
    "ConfigError",
    "ConfigSummary",
    "EpisodeStats",
    "ExperimentResult",
    "ExperimentSpec",
    "MgraoError",
    "NumericalError",
    "Parameter",
    "Preset",
    "Run",
    "SystemParams",
    "TaskCounts",
    "WorkLimitError",
    "complete_params",
    "divisors",
    "episode_band",
    "final_utilities",
    "get_preset",
    "identity_params",
    "make_params",
    "make_spec",
    "parent_groups",
    "parse_algorithm",
    "plan_chunks",
    "run_chunk",
    "run_experiment",
    "spec_from_dict",
    "paired_pct_from_uniform",
    "summarise",
]
