"""What a ``POST /api/jobs`` body asks the core to run: its spec and, with ``until``, its stopping rule.

One reading for every route that takes a job's body (a submission, a batch of them, ``POST /api/jobs/check``);
the core validates both (:func:`mgrao_core.make_spec`, :func:`mgrao_core.statistics.sequential.until_spec`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from backend.api.schemas import JobCreate
from mgrao_core import ConfigError, ExperimentSpec, make_spec
from mgrao_core.statistics.sequential import Until, until_spec


def experiment(job: JobCreate, system: str, overrides: Mapping[str, Any],
               memory_budget: int) -> tuple[ExperimentSpec, Until | None]:
    """The spec the job runs (``system`` and ``overrides`` resolved from a saved system) and its rule, or None.

    Raises:
        ConfigError: naming the field: the core's, ``seeds`` given beside ``until``, ``first_seed`` without it.
    """
    if job.until is None:
        if job.first_seed is not None:
            raise ConfigError("first_seed", "goes with until (without a rule, give the seeds as a list)")
        return make_spec(system, job.algorithms, job.seeds, job.episodes, overrides, memory_budget=memory_budget), None
    if "seeds" in job.model_fields_set:
        raise ConfigError("seeds", "give either seeds or until: a rule runs as many seeds as its question needs "
                                   "(until.max_seeds bounds them, from first_seed)")
    return until_spec(system, job.algorithms, job.first_seed or 0, job.episodes, overrides, job.until.model_dump(),
                      memory_budget=memory_budget)
