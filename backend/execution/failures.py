"""How an error that ends a job becomes its stored failure: the one mapping, :func:`failure`.

Only the core is imported here, so that a Dask task (:func:`backend.execution.dask_tasks.simulate_batch`)
maps a small job's error where it happened and returns a :class:`Failure`, which pickles (some of the
core's errors do not).
"""

from __future__ import annotations

from dataclasses import dataclass

from mgrao_core import MgraoError, NumericalError


@dataclass(frozen=True)
class Failure:
    """How a job that raised ends: its stored error message, and whether its stored runs are dropped."""

    message: str
    discard_runs: bool = False


def failure(error: BaseException, *, where: str = "") -> Failure:
    """The one mapping from an error that ends a job to its failure.

    A numerical error drops the stored runs (their numbers are suspect), an error of the core is
    its own message, anything else (a bug) names its type, after ``where`` (the chunk it came from).
    """
    if isinstance(error, NumericalError):
        return Failure(str(error), discard_runs=True)
    if isinstance(error, MgraoError):
        return Failure(str(error))
    return Failure(f"{where}{type(error).__name__}: {error}")
