"""What the ``runs`` table keeps of one simulated run: its columns, within stated bounds.

One home for a run's stored form, shared by a local worker (which stores it) and a Dask worker (which sends it
back to the dispatcher: :mod:`backend.execution.dask_tasks`), so that nothing is shipped that is not stored.
Only numpy and the core are imported: a Dask worker needs no database.

* ``utilities``: every episode, little-endian float64 (episode ``e`` at byte ``8 e``).
* ``combined_weights`` and ``group_weights``: the final weights as :func:`mgrao_core.budget.stored_weights` bounds
  them: every child's while they fit (16 MB each), else the first children's that fit; with several resources,
  resource-major (each resource's kept children in turn). ``group_shape`` is the run's whole shape
  ``[resources x children, groups, types]`` whatever is kept.
* ``weights_meta``: what was kept (:func:`weights_meta`); null for runs stored before it existed (migration 0017),
  which kept every weight.
* ``child_means``: for a run of more than :data:`~mgrao_core.budget.MEAN_ABOVE_CHILDREN` children, the weights'
  mean over every child: the combined ``(resources, types)`` then, where kept, the PW ``(resources, groups,
  types)``, float64.
* ``membership``: an algorithm whose groups change keeps its recorded memberships, int16, of the first children
  within :data:`MAX_MEMBERSHIP_VALUES`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from mgrao_core import Run as SimulatedRun
from mgrao_core.budget import StoredWeights, stored_weights

MAX_MEMBERSHIP_VALUES = 100_000
"""Recorded memberships stored per run (children x records x parents, int16): the first children that fit,
at least one (records are at most :data:`mgrao_core.algorithms.adaptive.SNAPSHOTS`)."""

StoredRun = dict[str, Any]
"""A run's columns as the ``runs`` table stores them, without its job (what a Dask worker sends back)."""


def blob(array: np.ndarray) -> bytes:
    """An array as little-endian float64 bytes, in C order."""
    return np.ascontiguousarray(array, dtype="<f8").tobytes()


def stored_run(run: SimulatedRun) -> StoredRun:
    """A simulated run's stored columns (see the module docstring)."""
    return ({"algorithm": run.algorithm, "seed": run.seed, "episodes": len(run.utilities),
             "utilities": blob(run.utilities)} | _weights(run) | _membership(run) | _tasks(run))


def stored_runs(runs: Iterable[SimulatedRun | StoredRun]) -> list[StoredRun]:
    """Every run's stored columns, in order; a run already in its stored form (from a Dask worker) as it is."""
    return [dict(run) if isinstance(run, Mapping) else stored_run(run) for run in runs]


def weights_meta(kept: StoredWeights) -> dict[str, Any]:
    """``runs.weights_meta``: a run's children, and how many of them each stored weight holds.

    ``{"children", "combined_children", "group_children", "means", "group_mean"}`` (see
    :class:`mgrao_core.budget.StoredWeights`).
    """
    return {"children": kept.children, "combined_children": kept.combined_children,
            "group_children": kept.group_children, "means": kept.means, "group_mean": kept.group_mean}


def _weights(run: SimulatedRun) -> dict[str, Any]:
    """A run's final weights as stored: with several resources, resource-major, each within its bound.

    One resource: ``combined (children, n_types)``, ``group (children, m, n_types)``, ``group_shape [children,
    m, n_types]``, as ever. ``R`` resources: ``combined (R, children, n_types)`` and ``group (R, children, m,
    n_types)``, ``group_shape [R * children, m, n_types]``: the first rows are the first resource's, so a reader
    that does not know the resources reads the first one (``n_resources`` is in the job's params). Of each, the
    first children that :func:`mgrao_core.budget.stored_weights` keeps.
    """
    if run.resource_weights is None:
        combined = run.combined_weights[np.newaxis]
        groups = run.group_weights[np.newaxis]
    else:
        combined = run.resource_weights
        groups = run.group_weights[np.newaxis] if run.resource_group_weights is None else run.resource_group_weights
    n_resources, children, n_types = combined.shape
    m = int(groups.shape[-2])
    kept = stored_weights(children, m, n_types, n_resources)
    out = {"combined_weights": blob(combined[:, : kept.combined_children]),
           "group_weights": blob(groups[:, : kept.group_children]),
           "group_shape": [n_resources * children, m, n_types], "weights_meta": weights_meta(kept),
           "child_means": None}
    if kept.means:
        means = [combined.mean(axis=1)] + ([groups.mean(axis=1)] if kept.group_mean else [])
        out["child_means"] = b"".join(blob(mean) for mean in means)
    return out


def _membership(run: SimulatedRun) -> dict[str, Any]:
    """A run's recorded memberships as int16 bytes and their shape (the first children within the bound)."""
    history = getattr(run, "membership", None)
    if history is None:
        return {"membership": None, "membership_meta": None}
    per_child = max(1, history.shape[1] * history.shape[2])
    kept = history[: max(1, MAX_MEMBERSHIP_VALUES // per_child)]
    return {"membership": np.ascontiguousarray(kept, dtype="<i2").tobytes(),
            "membership_meta": {"shape": list(kept.shape), "every": int(run.membership_every)}}


def _tasks(run: SimulatedRun) -> dict[str, int]:
    """A run's task counts as its three columns."""
    return {"tasks_allocated": int(run.tasks.allocated), "tasks_failed": int(run.tasks.failed),
            "tasks_handed_over": int(run.tasks.handed_over)}


def stored_bytes(row: Mapping[str, Any]) -> int:
    """Bytes of a stored run's columns that grow with its size (what a batch counts before storing them)."""
    return sum(len(row.get(column) or b"") for column in ("utilities", "combined_weights", "group_weights",
                                                          "child_means", "membership"))
