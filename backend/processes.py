"""The processes that run jobs, wired to the studies: a local worker and the Dask dispatcher.

Job execution (:mod:`backend.execution.worker` and :mod:`backend.execution.dispatcher`, through
:mod:`backend.execution.lifecycle`) knows nothing of studies: here the studies subscribe to the end
of every job (:data:`ON_ENDED`), so that a study advances as soon as one of its trials' jobs ends. ``mgrao worker`` runs
:func:`run_worker`, ``mgrao serve`` starts its workers as ``python -P -m backend.processes``, and
``mgrao dispatcher`` runs :func:`run_dispatcher`.
"""

from __future__ import annotations

from backend.execution import worker
from backend.execution.lifecycle import Ended
from backend.services import studies
from backend.settings import Settings

ON_ENDED: tuple[Ended, ...] = (studies.hand_over_or_advance,)
"""What is told that a job ended, in every process that runs jobs (under ``mgrao serve``, the API's study driver
advances the studies: :mod:`backend.wakeup`)."""


def local_worker(settings: Settings, *, worker_id: str | None = None) -> worker.Worker:
    """A local worker whose ended jobs advance their studies."""
    return worker.Worker(settings, worker_id=worker_id, on_ended=ON_ENDED)


def run_worker(settings: Settings | None = None) -> None:
    """A local worker process until it is stopped."""
    worker.main(settings, on_ended=ON_ENDED)


def run_dispatcher(settings: Settings | None = None, address: str | None = None) -> None:
    """The Dask dispatcher process until it is stopped."""
    from backend.execution import dispatcher  # Dask is imported by the dispatcher only, not by every worker

    dispatcher.main(settings, address, on_ended=ON_ENDED)


if __name__ == "__main__":
    run_worker()
