"""What runs on a Dask worker: the kernel warm-up, one chunk of a job, and a batch of small jobs.

Only the core and the runs' stored form (:mod:`backend.store.run_storage`, numpy only) are imported here: a Dask
worker needs the project installed (the same image as the service, so that versions match) but no access to the
database, and sends back each run as it is stored, so that what the service does not keep never crosses the
network. The dispatcher
(:mod:`backend.execution.dispatcher`) sends each chunk or batch as a task and stores what comes back.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any

from distributed import WorkerPlugin

if TYPE_CHECKING:
    from backend.execution.failures import Failure

log = logging.getLogger("mgrao.dask")
PLUGIN_NAME = "mgrao-warm-up"


class WarmUp(WorkerPlugin):
    """Loads (or compiles) the numba kernel of the paper's configurations once per Dask worker, before any chunk."""

    name = PLUGIN_NAME

    def setup(self, worker: Any) -> None:
        """Run a tiny experiment: afterwards a chunk of MG-RAO and fixed configurations finds its kernel loaded.

        A chunk with other learners, or several resources, loads (or compiles, once) its own
        combination (:mod:`mgrao_core.engine.kernel`).
        """
        from mgrao_core import make_spec, run_experiment

        run_experiment(make_spec("single", seeds=1, episodes=2))


def simulate_chunk(config: dict[str, Any], seeds: list[int], memory_budget: int) -> list[dict[str, Any]]:
    """Every algorithm of a job's configuration over ``seeds``: the core's runs, in order, as they are stored.

    The configuration is validated again here, as a local worker does; the numbers are those of
    :func:`mgrao_core.run_chunk`, whatever machine computes them. Each run comes back in its stored form
    (:func:`backend.store.run_storage.stored_run`): what the service does not store is not sent.
    """
    from backend.store.run_storage import stored_runs
    from mgrao_core import run_chunk, spec_from_dict

    spec = spec_from_dict(config, memory_budget=memory_budget)
    return stored_runs(run_chunk(spec, seeds))


def simulate_batch(jobs: list[tuple[int, dict[str, Any], list[list[int]]]],
                   memory_budget: int) -> list[tuple[int, list[dict[str, Any]] | Failure]]:
    """A batch of small jobs, each ``(job id, configuration, chunks of seeds left)``, run whole, one after another.

    Each job runs as a local worker runs it in a batch (:func:`backend.execution.small_jobs.run_small_job`,
    on one numba thread), its runs sent back in their stored form (as :func:`simulate_chunk`'s); one job's
    error is returned in its place as its :class:`~backend.execution.failures.Failure` (mapped here, by the one
    mapping, and picklable where some of the core's errors are not), not raised, so that it fails only that job.
    Nothing here touches the database: the dispatcher stores what comes back.
    """
    from backend.execution.failures import failure
    from backend.execution.small_jobs import one_numba_thread, run_small_job
    from backend.store.run_storage import stored_runs
    from mgrao_core import MgraoError, spec_from_dict

    results: list[tuple[int, list[dict[str, Any]] | Failure]] = []
    with one_numba_thread():
        for job_id, config, chunks in jobs:
            try:
                spec = spec_from_dict(config, memory_budget=memory_budget)
                results.append((job_id, stored_runs(run_small_job(spec, chunks))))
            except Exception as error:  # noqa: BLE001 - it fails that job only
                if not isinstance(error, MgraoError):  # a bug: its traceback goes to the Dask worker's log
                    log.exception("job %s failed", job_id)
                results.append((job_id, failure(error)))
    return results
