"""Small jobs, run in batches: the one home shared by local workers and the Dask dispatcher.

Which job is small (:func:`small_spec`), how a batch is cut to a memory bound (:func:`packed`) and
how a small job runs whole (:func:`run_small_job`). Only the core is imported at run time, so that
a Dask worker (:func:`backend.execution.dask_tasks.simulate_batch`) needs no database access. A
local worker (:meth:`backend.execution.worker.Worker.execute_batch`) and the dispatcher's batch
task run each small job of a batch with :func:`run_small_job`, on one numba thread.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from backend.settings import Settings
    from backend.store.queue import Claim
    from mgrao_core import ExperimentSpec

SMALL_JOB_BYTES = 64 * 1024**2
"""The most memory a job run in a batch may take, every seed at once (:func:`mgrao_core.budget.chunk_cost`)."""

BATCH_BYTES = 64 * 1024**2
"""Done runs a batch holds at most before they are stored: beyond, a local worker stores what is
done before the rest runs, and the dispatcher cuts its claimed batches into Dask tasks whose runs
take at most this much (:func:`packed`)."""


def run_bytes(spec: ExperimentSpec) -> int:
    """Memory a job's runs take once done, every seed (``results`` of :func:`mgrao_core.budget.chunk_cost`)."""
    from mgrao_core.budget import chunk_cost

    return chunk_cost(spec, len(spec.seeds)).results


def small_spec(settings: Settings, claim: Claim) -> ExperimentSpec | None:
    """A claimed small job's validated configuration, parsed once for its batch; None when it runs alone.

    Small in work (``MGRAO_SMALL_JOB_WORK`` atomic tasks) and in memory: a batch holds each job's runs
    whole, so a job whose every seed at once would take more than :data:`SMALL_JOB_BYTES` (few
    tasks, but large learner state or stored weights) runs alone, chunk by chunk, within its budget.
    """
    if claim.work is None or claim.work > settings.small_job_work or claim.config.get("until") is not None:
        return None  # a job with a stopping rule runs a block at a time, judged between blocks
    from mgrao_core import spec_from_dict
    from mgrao_core.budget import chunk_cost

    try:
        spec = spec_from_dict(claim.config, memory_budget=settings.job_memory_bytes)
    except Exception:  # noqa: BLE001  (an invalid configuration fails when it is planned, with its message)
        return None
    return spec if chunk_cost(spec, len(spec.seeds)).total <= SMALL_JOB_BYTES else None


def packed(claims: Sequence[Claim], specs: Mapping[int, ExperimentSpec],
           limit: int = BATCH_BYTES) -> list[list[Claim]]:
    """``claims`` in order, cut into batches whose jobs' summed :func:`run_bytes` stays within ``limit``.

    A batch run whole (one Dask task, on one Dask worker thread) then holds at most ``limit`` of done
    runs plus the one job running (itself within :data:`SMALL_JOB_BYTES`) until its results are
    fetched. A job alone over ``limit`` gets a batch of its own.
    """
    batches: list[list[Claim]] = []
    held = limit + 1
    for claim in claims:
        cost = run_bytes(specs[claim.job_id])
        if held + cost > limit:
            batches.append([])
            held = 0
        batches[-1].append(claim)
        held += cost
    return batches


@contextmanager
def one_numba_thread() -> Iterator[None]:
    """Run the kernel on one thread, in this block.

    For a small job's few lanes, waking numba's thread pool costs more than the simulation: 3 to 5 ms
    a call on a busy 2-core machine, against 0.4 ms on one thread.
    """
    import numba

    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(before)


def run_small_job(spec: ExperimentSpec, chunks: Sequence[Sequence[int]],
                  should_stop: Callable[[], bool] | None = None, on_compile: Callable[..., None] | None = None) -> list:
    """Every run of a small job's remaining ``chunks``, in order (raises what :func:`mgrao_core.run_chunk` raises).

    ``on_compile`` is told of a compile of the engine for it (:class:`mgrao_core.compiling.Compiling`).
    """
    from mgrao_core import run_chunk

    return [run for chunk in chunks
            for run in run_chunk(spec, tuple(chunk), should_stop=should_stop, on_compile=on_compile)]
