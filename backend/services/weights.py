"""Final learned weights of a job's runs: one seed's own, or the mean over its seeds, a page of children at a time.

Every seed draws its own composite types and value profiles, so the mean over seeds washes out
the structure a learner found; one seed's weights show it, and the ``oracle``'s allocation for the
same seed (where the job ran the oracle) shows what the best fixed allocation would be.

An answer holds a page of children (:data:`CHILDREN_PAGE` by default, every child of a system of at most that
many; ``child_offset`` and ``children`` choose another, up to :data:`MAX_CHILDREN_PAGE`), read from the stored
weights by byte range (SQL ``substr``), so that a run's whole weights are never loaded for one page. A run of
more children also answers their mean over every child (``mean_over_children``, stored with the run). Parent-group
weights beyond :data:`MAX_WEIGHT_VALUES` per page, or of children whose PW a run did not store
(:func:`mgrao_core.budget.stored_weights`), are left out with the reason.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import Integer, LargeBinary, cast, func, select
from sqlalchemy.orm import Session

from backend.errors import BadQuery, Conflict
from backend.store.crud import get_job
from backend.store.models import RUN_READ_BATCH, Job, Run
from mgrao_core.budget import MAX_STORED_COMBINED_VALUES, MAX_STORED_GROUP_VALUES

MAX_WEIGHT_VALUES = 200_000
"""Learned weights shown per configuration and page (children x groups x types); larger PW are left out."""
CHILDREN_PAGE = 100
"""Children an answer holds by default: every child of a system of at most 100 (every system before sparse
worlds), the first 100 of a larger one."""
MAX_CHILDREN_PAGE = 1_000
"""Children one answer may ask for (``children``)."""
_F = 8  # bytes of a stored float64


@dataclass(frozen=True)
class Layout:
    """How a run's final weights are stored (:mod:`backend.store.run_storage`), and which page an answer reads.

    Attributes:
        children: the run's children.
        combined_children: the first children whose combined weights are stored.
        group_children: the first children whose parent-group weights (PW) are stored.
        groups: parent groups per child (0: the algorithm learns none).
        types: atomic task types.
        resources: resources whose weights are stored, resource-major.
        means: whether the run stored its weights' mean over every child.
        group_mean: whether that mean includes the PW's.
    """

    children: int
    combined_children: int
    group_children: int
    groups: int
    types: int
    resources: int
    means: bool = False
    group_mean: bool = False

    @classmethod
    def of(cls, shape: list[int], meta: dict[str, Any] | None, n_resources: int) -> Layout:
        """A run's layout from its ``group_shape``, ``weights_meta`` (null: every weight kept) and resources."""
        rows, groups, types = (list(shape) + [0, 0, 0])[:3] if shape else (0, 0, 0)
        children = rows // n_resources
        if meta is None:
            return cls(children, children, children, groups, types, n_resources)
        return cls(children, meta["combined_children"], meta["group_children"], groups, types, n_resources,
                   bool(meta.get("means")), bool(meta.get("group_mean")))

    def combined_page(self, offset: int, count: int) -> list[Any]:
        """SQL expressions of each resource's combined weights of children ``offset .. offset + count - 1``."""
        row = self.types * _F
        return [_substr(Run.combined_weights, (r * self.combined_children + offset) * row, count * row)
                for r in range(self.resources)]

    def group_page(self, offset: int, count: int) -> list[Any]:
        """SQL expressions of each resource's PW of children ``offset .. offset + count - 1``."""
        row = self.groups * self.types * _F
        return [_substr(Run.group_weights, (r * self.group_children + offset) * row, count * row)
                for r in range(self.resources)]

    def groups_shown(self, offset: int, count: int) -> str | None:
        """None when the page's PW are answered; else why not (the algorithm learns PW: ``groups`` > 0)."""
        values = self.resources * count * self.groups * self.types
        if values > MAX_WEIGHT_VALUES:
            if offset == 0 and count == self.children:  # the whole run, as answered before pages existed
                return f"{values:,} parent-group weights per run exceed the {MAX_WEIGHT_VALUES:,} shown"
            fit = MAX_WEIGHT_VALUES // (self.resources * self.groups * self.types)
            ask = f": ask for at most {fit:,} children" if fit else " (one child's are more than that)"
            return (f"{values:,} parent-group weights of {count:,} children exceed the {MAX_WEIGHT_VALUES:,} an "
                    f"answer shows{ask}")
        if offset + count > self.group_children:
            mean = "; their mean over every child is in mean_over_children" if self.group_mean else ""
            return (f"a run stores the parent-group weights of its first {self.group_children:,} of "
                    f"{self.children:,} children (at most {MAX_STORED_GROUP_VALUES:,} values){mean}")
        return None

    @property
    def mean_groups_shown(self) -> bool:
        """Whether the answers show the PW's mean over children: stored, and within :data:`MAX_WEIGHT_VALUES`."""
        return self.group_mean and self.resources * self.groups * self.types <= MAX_WEIGHT_VALUES

    def means_column(self) -> Any:
        """SQL expression of what an answer reads of the run's means over children: the PW's only where shown."""
        return _substr(Run.child_means, 0, self.resources * self.types * (1 + self.groups * self.mean_groups_shown)
                       * _F)

    def mean_omitted(self) -> str:
        """Why an answer's mean over children has no PW (the algorithm learns them)."""
        values = self.resources * self.groups * self.types
        if not self.group_mean:
            return (f"one child's {values:,} parent-group weights exceed the {MAX_STORED_GROUP_VALUES:,} a run "
                    "stores: their mean over children was not stored")
        return f"{values:,} parent-group weights exceed the {MAX_WEIGHT_VALUES:,} shown"

    def stored_note(self) -> dict[str, Any]:
        """What each run of this layout keeps, as the ``children`` of an answer states it."""
        return {"total": self.children, "combined_stored": self.combined_children,
                "groups_stored": self.group_children if self.groups else None,
                "bounds": {"combined_values": MAX_STORED_COMBINED_VALUES, "group_values": MAX_STORED_GROUP_VALUES}}


def _substr(column: Any, start: int, length: int) -> Any:
    """``length`` bytes of a blob column from byte ``start`` (SQL ``substr`` counts from 1, on either database)."""
    return func.substr(column, cast(start + 1, Integer), cast(length, Integer), type_=LargeBinary)


def n_resources_of(config: dict[str, Any], shape: list[int]) -> int:
    """The resources whose weights a run of a job stored: 1, or ``n_resources`` when stored resource-major.

    ``n_resources`` is in a job's params only away from its default, 1. A simulated run of several resources
    stores ``n_resources * n_children`` rows (:mod:`backend.store.run_storage`); an external run's
    weights are one allocation per child whatever its system says.
    """
    params = config.get("params") or {}
    n_resources = int(params.get("n_resources", 1))
    if n_resources > 1 and shape and shape[0] == n_resources * int(params.get("n_children", -1)):
        return n_resources
    return 1


def _answer(combined: np.ndarray, groups: np.ndarray | None, n_groups: int, omitted: str | None) -> dict[str, Any]:
    """``combined (resources, children, types)`` and ``groups (resources, children, m, types)`` as answered.

    ``combined`` and ``groups`` are the first resource's ([] for ``groups`` when the algorithm learns none, null
    with ``groups_omitted`` when they are left out); with several resources, ``resources`` gives each one's.
    """
    out: dict[str, Any] = {"combined": combined[0].tolist(), "groups": []}
    if groups is not None:
        out["groups"] = groups[0].tolist()
    elif n_groups > 0:
        out["groups"] = None
        out["groups_omitted"] = omitted
    if combined.shape[0] > 1:
        out["resources"] = [{"resource": r, "combined": combined[r].tolist(),
                             "groups": out["groups"] if groups is None else groups[r].tolist()}
                            for r in range(combined.shape[0])]
    return out


def membership_history(blob: bytes, meta: dict[str, Any]) -> np.ndarray:
    """A run's recorded memberships as stored, ``(children, records, n_parents)``: each parent's group."""
    return np.frombuffer(blob, dtype="<i2").reshape(meta["shape"])


def _means(blob: bytes | None, layout: Layout) -> tuple[np.ndarray, np.ndarray | None] | None:
    """A run's mean over every child as read (:meth:`Layout.means_column`).

    Combined ``(resources, 1, types)``, and PW ``(resources, 1, m, types)`` where shown.
    """
    if not layout.means or not blob:
        return None
    values = np.frombuffer(blob, dtype="<f8")
    split = layout.resources * layout.types
    combined = values[:split].reshape(layout.resources, 1, layout.types)
    if not layout.mean_groups_shown:
        return combined, None
    return combined, values[split:].reshape(layout.resources, 1, layout.groups, layout.types)


def _page(layout: Layout, offset: int, count: int) -> dict[str, Any]:
    return {"offset": offset, "count": count} | layout.stored_note()


def _paged(layout: Layout, asked: bool) -> bool:
    """Whether an answer says which children it holds: asked for a page, or a run of more than a page."""
    return asked or layout.children > CHILDREN_PAGE


def _first_layout(session: Session, job: Job, *where: Any) -> Layout | None:
    first = session.execute(select(Run.group_shape, Run.weights_meta).where(Run.job_id == job.id, *where)
                            .limit(1)).first()
    if first is None:
        return None
    return Layout.of(list(first[0]), first[1], n_resources_of(job.config, list(first[0])))


def mean_over_seeds(session: Session, job_id: int, algorithm: str) -> dict[str, Any]:
    """The mean over the stored seeds of a configuration's final weights, of the first page of children.

    Every run of a configuration has the same layout: only the page's bytes of each are read (PW too large to
    show never); a run of more than a page of children adds ``children`` and the mean of its stored
    ``mean_over_children``.
    """
    job = get_job(session, job_id=job_id)
    of_config = (Run.job_id == job_id, Run.algorithm == algorithm)
    layout = _first_layout(session, job, Run.algorithm == algorithm)
    if layout is None:
        return {"combined": [], "groups": []}
    count = min(CHILDREN_PAGE, layout.combined_children)
    omitted = layout.groups_shown(0, count) if layout.groups else None
    read_groups = layout.groups > 0 and omitted is None
    columns = [*layout.combined_page(0, count), *(layout.group_page(0, count) if read_groups else ()),
               layout.means_column()]
    combined_sum = groups_sum = None
    means_sum: list[np.ndarray | None] | None = None
    runs = mean_runs = 0
    for row in session.execute(select(*columns).where(*of_config).execution_options(yield_per=RUN_READ_BATCH)):
        combined = b"".join(part or b"" for part in row[: layout.resources])
        if not combined:  # a run logged from outside without its final weights
            continue
        values = np.frombuffer(combined, dtype="<f8")
        combined_sum = values.copy() if combined_sum is None else combined_sum + values
        if read_groups:
            values = np.frombuffer(b"".join(row[layout.resources: 2 * layout.resources]), dtype="<f8")
            groups_sum = values.copy() if groups_sum is None else groups_sum + values
        means = _means(row[-1], layout)
        if means is not None:
            means_sum = list(means) if means_sum is None else [
                a + b if a is not None and b is not None else None for a, b in zip(means_sum, means, strict=True)]
            mean_runs += 1
        runs += 1
    if combined_sum is None:  # deleted meanwhile
        return {"combined": [], "groups": []}
    groups = None if groups_sum is None else (groups_sum / runs).reshape(layout.resources, count, layout.groups,
                                                                         layout.types)
    out = _answer((combined_sum / runs).reshape(layout.resources, count, -1), groups, layout.groups, omitted)
    if _paged(layout, False):
        out["children"] = _page(layout, 0, count)
    if means_sum is not None:
        combined_mean, groups_mean = (None if mean is None else mean / mean_runs for mean in means_sum)
        out["mean_over_children"] = _answer(combined_mean, groups_mean, layout.groups, layout.mean_omitted())
    return out


def _membership(blob: bytes, meta: dict[str, Any], offset: int, count: int) -> dict[str, Any]:
    """A run's recorded memberships of the page's children that are stored, and the episodes between records.

    Per child, per record, each parent's group.
    """
    history = membership_history(blob, meta)
    return {"every": meta["every"], "children": history[offset: offset + count].tolist()}


def _page_of(layout: Layout, job_id: int, child_offset: int | None, children: int | None) -> tuple[int, int]:
    """The page an answer holds, within the stored children; 422 naming the field beyond them."""
    offset = child_offset or 0
    if offset >= layout.children:
        raise BadQuery("child_offset", f"must be below n_children = {layout.children:,} (got {offset:,})")
    if offset >= layout.combined_children:
        raise BadQuery("child_offset", f"a run of job {job_id} stores the combined weights of its first "
                                       f"{layout.combined_children:,} of {layout.children:,} children (at most "
                                       f"{MAX_STORED_COMBINED_VALUES:,} values): must be below "
                                       f"{layout.combined_children:,} (got {offset:,})")
    count = min(CHILDREN_PAGE if children is None else children, layout.combined_children - offset)
    per_child = layout.resources * layout.types
    if count * per_child > MAX_WEIGHT_VALUES:
        raise BadQuery("children", f"{count:,} children x {per_child:,} combined weights exceed the "
                                   f"{MAX_WEIGHT_VALUES:,} an answer holds: ask for at most "
                                   f"{MAX_WEIGHT_VALUES // per_child:,}")
    return offset, count


def of_seed(session: Session, *, job_id: int, seed: int | None = None, child_offset: int | None = None,
            children: int | None = None) -> dict[str, Any]:
    """``GET /api/jobs/{id}/weights`` (docs/api.md "Weights"): every configuration's final weights for one seed.

    A configuration whose parent groups change (``mgrao-adaptive:x``, ``mgrao-balance``) also gives its recorded
    memberships. ``child_offset`` and ``children`` choose the page of children (default: the first
    :data:`CHILDREN_PAGE`); an answer of a page, or of a run of more children, says which (``children``), and
    a run of more than :data:`~mgrao_core.budget.MEAN_ABOVE_CHILDREN` children adds its ``mean_over_children``.

    ``seed`` None: the job's first seed that has stored runs. A seed that is not the job's is
    refused (422 naming ``seed``), as is a page beyond the stored children (422 naming ``child_offset``, or
    ``children`` beyond what an answer holds); one of its seeds with no run stored yet is a conflict (409).
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
    asked = child_offset is not None or children is not None
    rows = session.execute(select(Run.id, Run.algorithm, Run.group_shape, Run.weights_meta, Run.membership_meta)
                           .where(Run.job_id == job_id, Run.seed == chosen)).all()
    rank = {a: i for i, a in enumerate(job.config["algorithms"])}
    layouts = {run_id: Layout.of(list(shape), meta, n_resources_of(job.config, list(shape)))
               for run_id, _, shape, meta, _ in rows}
    offset, count = _page_of(layouts[rows[0][0]], job_id, child_offset, children)
    configurations = []
    for run_id, algorithm, _, _, membership_meta in sorted(rows, key=lambda r: rank.get(r[1], len(rank))):
        layout = layouts[run_id]
        omitted = layout.groups_shown(offset, count) if layout.groups else None
        reads = [*layout.combined_page(offset, count),
                 *(layout.group_page(offset, count) if layout.groups and omitted is None else ()),
                 layout.means_column()]
        blobs = session.execute(select(*reads).where(Run.id == run_id)).one()
        combined = np.frombuffer(b"".join(part or b"" for part in blobs[: layout.resources]), dtype="<f8").reshape(
            layout.resources, count, -1)  # (resources, count, 0) for a run logged without its final weights
        groups = None
        if layout.groups and omitted is None:  # a PW too large to show, or not stored, is never read
            groups = np.frombuffer(b"".join(blobs[layout.resources: 2 * layout.resources]), dtype="<f8").reshape(
                layout.resources, count, layout.groups, layout.types)
        answer = {"algorithm": algorithm} | _answer(combined, groups, layout.groups, omitted)
        if _paged(layout, asked):
            answer["children"] = _page(layout, offset, count)
        means = _means(blobs[-1], layout)
        if means is not None:
            answer["mean_over_children"] = _answer(means[0], means[1], layout.groups, layout.mean_omitted())
        answer["membership"] = None if not membership_meta else _membership(
            session.scalar(select(Run.membership).where(Run.id == run_id)), membership_meta, offset, count)
        configurations.append(answer)
    return {"job_id": job_id, "seed": chosen, "seeds": stored, "configurations": configurations}

