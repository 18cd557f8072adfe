"""Running a small job whole, the one home shared by local workers and Dask tasks.

Only the core is imported here, so that a Dask worker (:mod:`backend.execution.dask_tasks`) needs
no database access. A local worker (:meth:`backend.execution.worker.Worker.execute_batch`) and the
dispatcher's batch task (:func:`backend.execution.dask_tasks.simulate_batch`) run each small job of a
batch with :func:`run_small_job`, on one numba thread.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mgrao_core import ExperimentSpec


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
                  should_stop: Callable[[], bool] | None = None) -> list:
    """Every run of a small job's remaining ``chunks``, in order (raises what :func:`mgrao_core.run_chunk` raises)."""
    from mgrao_core import run_chunk

    return [run for chunk in chunks for run in run_chunk(spec, tuple(chunk), should_stop=should_stop)]
