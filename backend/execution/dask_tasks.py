"""What runs on a Dask worker: the kernel warm-up, and one chunk of a job.

Only the core is imported here: a Dask worker needs the project installed (the same image as the
service, so that versions match) but no access to the database. The dispatcher
(:mod:`backend.execution.dispatcher`) sends each chunk as a task and stores what comes back.
"""

from __future__ import annotations

from typing import Any

from distributed import WorkerPlugin

PLUGIN_NAME = "mgrao-warm-up"


class WarmUp(WorkerPlugin):
    """Loads (or compiles) the numba kernel once per Dask worker, before its first chunk."""

    name = PLUGIN_NAME

    def setup(self, worker: Any) -> None:
        """Run a tiny experiment: afterwards every chunk finds the kernel loaded."""
        from mgrao_core import make_spec, run_experiment

        run_experiment(make_spec("single", seeds=1, episodes=2))


def simulate_chunk(config: dict[str, Any], seeds: list[int], memory_budget: int) -> list:
    """Every algorithm of a job's configuration over ``seeds``: the core's runs, in order.

    The configuration is validated again here, as a local worker does; the numbers are those of
    :func:`mgrao_core.run_chunk`, whatever machine computes them.
    """
    from mgrao_core import run_chunk, spec_from_dict

    spec = spec_from_dict(config, memory_budget=memory_budget)
    return list(run_chunk(spec, seeds))


def simulate_batch(jobs: list[tuple[int, dict[str, Any], list[list[int]]]],
                   memory_budget: int) -> list[tuple[int, list | BaseException]]:
    """A batch of small jobs, each ``(job id, configuration, chunks of seeds left)``, run whole, one after another.

    Each job runs as a local worker runs it in a batch (:func:`backend.execution.small_jobs.run_small_job`,
    on one numba thread); one job's error is returned in its place, not raised, so that it fails only
    that job. Nothing here touches the database: the dispatcher stores what comes back.
    """
    from backend.execution.small_jobs import one_numba_thread, run_small_job
    from mgrao_core import MgraoError, spec_from_dict

    results: list[tuple[int, list | BaseException]] = []
    with one_numba_thread():
        for job_id, config, chunks in jobs:
            try:
                results.append((job_id, run_small_job(spec_from_dict(config, memory_budget=memory_budget), chunks)))
            except MgraoError as error:
                results.append((job_id, error))
            except Exception as error:  # noqa: BLE001 - a bug: its type and message fail that job only
                results.append((job_id, RuntimeError(f"{type(error).__name__}: {error}")))
    return results
