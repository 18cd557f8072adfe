"""Final learned weights of a job's runs: the mean over its seeds, or one seed's own.

Every seed draws its own composite types and value profiles, so the mean over seeds washes out
the structure a learner found; one seed's weights show it, and the ``oracle``'s allocation for the
same seed (where the job ran the oracle) shows what the best fixed allocation would be. Each run
is read once; parent-group weights beyond :data:`MAX_WEIGHT_VALUES` per run are left out with
the reason, so an answer holds at most that many per configuration.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session

from backend.errors import BadQuery, Conflict
from backend.store.crud import get_job
from backend.store.models import RUN_READ_BATCH, Run

MAX_WEIGHT_VALUES = 200_000
"""Learned weights shown per configuration (children x groups x types); larger PW are left out."""


def _shown(shape: list[int]) -> bool:
    return bool(shape) and shape[1] > 0 and math.prod(shape) <= MAX_WEIGHT_VALUES


def n_resources_of(config: dict[str, Any], shape: list[int]) -> int:
    """The resources whose weights a run of a job stored: 1, or ``n_resources`` when stored resource-major.

    ``n_resources`` is in a job's params only away from its default, 1. A simulated run of several resources
    stores ``n_resources * n_children`` rows (:func:`backend.store.queue._weights`); an external run's
    weights are one allocation per child whatever its system says.
    """
    params = config.get("params") or {}
    n_resources = int(params.get("n_resources", 1))
    if n_resources > 1 and shape and shape[0] == n_resources * int(params.get("n_children", -1)):
        return n_resources
    return 1


def _answer(combined: np.ndarray, groups: np.ndarray | None, shape: list[int], n_resources: int = 1) -> dict[str, Any]:
    """``combined`` per child, ``groups`` per child and group ([] when the algorithm learns none).

    With several resources the stored rows are resource-major (:func:`backend.store.queue._weights`): the answer's
    ``combined`` and ``groups`` are the first resource's, and ``resources`` gives each one's.
    """
    n_rows = shape[0] if shape else 1
    per_resource = combined.reshape(n_resources, n_rows // n_resources if n_resources > 1 else n_rows, -1)
    out: dict[str, Any] = {"combined": per_resource[0].tolist(), "groups": []}
    group_rows: np.ndarray | None = None
    if groups is not None:
        group_rows = groups.reshape(n_resources, -1, *shape[1:]) if n_resources > 1 else groups.reshape(1, *shape)
        out["groups"] = group_rows[0].tolist()
    elif shape and shape[1] > 0:
        out["groups"] = None
        out["groups_omitted"] = (f"{math.prod(shape):,} parent-group weights per run exceed the "
                                 f"{MAX_WEIGHT_VALUES:,} shown")
    if n_resources > 1 and per_resource.shape[0] == n_resources:
        out["resources"] = [{"resource": r, "combined": per_resource[r].tolist(),
                             "groups": out["groups"] if out["groups"] in ([], None) else group_rows[r].tolist()}
                            for r in range(n_resources)]
    return out


def membership_history(blob: bytes, meta: dict[str, Any]) -> np.ndarray:
    """A run's recorded memberships as stored, ``(children, records, n_parents)``: each parent's group."""
    return np.frombuffer(blob, dtype="<i2").reshape(meta["shape"])


def _membership(blob: bytes, meta: dict[str, Any]) -> dict[str, Any]:
    """A run's recorded memberships: per child, per record, each parent's group; and the episodes between records."""
    return {"every": meta["every"], "children": membership_history(blob, meta).tolist()}


def mean_over_seeds(session: Session, job_id: int, algorithm: str) -> dict[str, Any]:
    """The mean over the stored seeds of a configuration's final weights (see :func:`_answer`).

    Every run of a configuration has the same shape: PW too large to show are never read.
    """
    job = get_job(session, job_id=job_id)
    of_config = (Run.job_id == job_id, Run.algorithm == algorithm)
    first = session.scalar(select(Run.group_shape).where(*of_config).limit(1))
    if first is None:
        return {"combined": [], "groups": []}
    shape = list(first)
    columns = (Run.combined_weights, Run.group_weights) if _shown(shape) else (Run.combined_weights,)
    combined: np.ndarray | None = None
    groups: np.ndarray | None = None
    count = 0
    for blobs in session.execute(select(*columns).where(*of_config).execution_options(yield_per=RUN_READ_BATCH)):
        if not blobs[0]:  # a run logged from outside without its final weights
            continue
        values = np.frombuffer(blobs[0], dtype="<f8")
        combined = values.copy() if combined is None else combined + values
        if len(blobs) > 1:
            values = np.frombuffer(blobs[1], dtype="<f8")
            groups = values.copy() if groups is None else groups + values
        count += 1
    if combined is None:  # deleted meanwhile
        return {"combined": [], "groups": []}
    return _answer(combined / count, None if groups is None else groups / count, shape,
                   n_resources_of(job.config, shape))


def of_seed(session: Session, *, job_id: int, seed: int | None = None) -> dict[str, Any]:
    """``GET /api/jobs/{id}/weights`` (docs/api.md "Weights"): every configuration's final weights for one seed.

    A configuration whose parent groups change (``mgrao-adaptive:x``, ``mgrao-balance``) also gives its recorded
    memberships.

    ``seed`` None: the job's first seed that has stored runs. A seed that is not the job's is
    refused (422 naming ``seed``); one of its seeds with no run stored yet is a conflict (409).
    """
    job = get_job(session, job_id=job_id)
    order = {s: i for i, s in enumerate(job.config["seeds"])}
    stored = sorted(session.scalars(select(Run.seed).where(Run.job_id == job_id).distinct()), key=order.__getitem__)
    if seed is not None and seed not in order:
        seeds = job.config["seeds"]
        listed = ", ".join(map(str, seeds[:5])) + (f", … ({len(seeds):,} seeds)" if len(seeds) > 5 else "")
        raise BadQuery("seed", f"{seed} is not a seed of job {job_id} (its seeds: {listed})")
    if not stored:
        raise Conflict(f"job {job_id} is {job.status} and has no stored runs yet")
    chosen = stored[0] if seed is None else seed
    if chosen not in stored:
        raise Conflict(f"seed {chosen} of job {job_id} has no stored runs yet ({len(stored):,} seeds stored)")
    rows = session.execute(select(Run.id, Run.algorithm, Run.combined_weights, Run.group_shape, Run.membership_meta)
                           .where(Run.job_id == job_id, Run.seed == chosen)).all()
    rank = {a: i for i, a in enumerate(job.config["algorithms"])}
    configurations = []
    for run_id, algorithm, combined_blob, group_shape, meta in sorted(rows, key=lambda r: rank.get(r[1], len(rank))):
        shape = list(group_shape)
        groups = None
        if _shown(shape):  # a PW too large to show is never read
            blob = session.scalar(select(Run.group_weights).where(Run.id == run_id))
            groups = np.frombuffer(blob, dtype="<f8")
        answer = {"algorithm": algorithm} | _answer(np.frombuffer(combined_blob, dtype="<f8"), groups, shape,
                                                    n_resources_of(job.config, shape))
        answer["membership"] = None if not meta else _membership(
            session.scalar(select(Run.membership).where(Run.id == run_id)), meta)
        configurations.append(answer)
    return {"job_id": job_id, "seed": chosen, "seeds": stored, "configurations": configurations}
