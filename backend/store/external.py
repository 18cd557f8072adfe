"""Data functions of runs logged from outside (docs/platform.md): open, take a batch, close, read the state.

An external run is a job of kind ``external`` (status ``open`` until closed, then ``succeeded``) whose
configuration is a simulated job's (system, resolved parameters, seeds, episodes) with its label as
the one algorithm: the same ``config_hash`` as a built-in job of the same world, so compare and the
job view pair it seed by seed with built-in runs. Its episodes arrive as *pieces* (a seed's episodes
``start .. start + n - 1``), kept in ``external_pieces`` until the seed's pieces cover every episode;
then they become the seed's :class:`~backend.store.models.Run` (the same little-endian float64 blob a
worker stores) and results read it as any other run.

Every batch is one write transaction on the job's locked row (``FOR UPDATE`` on PostgreSQL; SQLite's
``BEGIN IMMEDIATE`` holds the database), recorded under the client's batch key: a batch sent again
with the same key and content is answered as the first time and stores nothing (``replayed``); the
same key with other content is a conflict. A piece identical to one already stored is skipped, any
other overlap refused, so nothing is ever stored twice however a client retries.
"""

from __future__ import annotations

import hashlib
import json
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from sqlalchemy import delete, func, select, update
from sqlalchemy.orm import Session

import mgrao_core
from backend.errors import Conflict, NotFound
from backend.store import summaries
from backend.store.crud import config_hash, index_labels, job_dict, set_tags
from backend.store.models import (
    EXTERNAL,
    OPEN,
    SUCCEEDED,
    ExternalBatch,
    ExternalPiece,
    ExternalRun,
    Job,
    Run,
    utcnow,
)

MAX_PIECES_PER_SEED = 1000
"""Pieces one seed's episodes may come in (a batch adds one piece per entry): send episodes in batches."""
MAX_BATCH_ENTRIES = 1000
"""Entries (pieces of utilities, or weights) of one batch."""
MAX_PIECE_VALUES = 10_000
"""Episode utilities of one piece (a 64 KiB body holds about 3,000): a longer seed comes in several pieces.

Every limit of a batch's schema is small enough that a body just past it is still under the default
body limit, so that it is refused naming the field (422) rather than for its size (413)."""


@dataclass(frozen=True)
class Piece:
    """Episodes ``start .. start + len(values) - 1`` of ``seed``, validated (finite, within the run)."""

    seed: int
    start: int
    values: np.ndarray


def _blob(values: np.ndarray) -> bytes:
    return np.ascontiguousarray(values, dtype="<f8").tobytes()


def definition_digest(label: str, config: dict[str, Any]) -> str:
    """sha256 of what an open key stands for: the label and the whole configuration (seeds included)."""
    text = json.dumps({"label": label, "config": config}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def get_external(session: Session, job_id: int, *, lock: bool = False) -> Job:
    """The external job ``job_id`` (locked for the transaction if asked), or :class:`NotFound`."""
    statement = select(Job).where(Job.id == job_id)
    if lock:
        statement = statement.with_for_update()  # PostgreSQL; SQLite's write transaction holds the database
    job = session.scalar(statement)
    if job is None:
        raise NotFound(f"external run {job_id} not found")
    if job.kind != EXTERNAL:
        raise NotFound(f"external run {job_id} not found: job {job_id} is a {job.kind} job")
    return job


def open_run(session: Session, *, config: dict[str, Any], name: str, tags: Sequence[str], notes: str,
             open_key: str | None) -> tuple[Job, bool]:
    """The run of ``open_key`` if one was opened with it (and the same definition), else a new one.

    Returns the job and whether it was created. Call inside a write transaction.

    Raises:
        Conflict: ``open_key`` opened a run of another definition.
    """
    label = config["algorithms"][0]
    digest = definition_digest(label, config)
    if open_key is not None:
        known = session.scalar(select(ExternalRun).where(ExternalRun.open_key == open_key))
        if known is not None:
            if known.definition_digest != digest:
                raise Conflict(f"key {open_key!r} already opened external run {known.job_id} with another label, "
                               "system, parameters, seeds or episodes: use another key")
            return get_external(session, known.job_id), False
    now = utcnow()
    job = Job(name=name, notes=notes, system=config["system"], config=config, config_hash=config_hash(config),
              kind=EXTERNAL, status=OPEN, progress=0.0, attempts=0, version=mgrao_core.__version__,
              created_at=now, started_at=now)
    set_tags(session, job, tags)
    index_labels(job)
    session.add(job)
    session.flush()
    session.add(ExternalRun(job_id=job.id, open_key=open_key, definition_digest=digest))
    session.flush()
    return job, True


def _stored_pieces(session: Session, job_id: int, seeds: set[int]) -> dict[int, list[tuple[int, int]]]:
    out: dict[int, list[tuple[int, int]]] = defaultdict(list)
    if seeds:
        rows = session.execute(select(ExternalPiece.seed, ExternalPiece.start, ExternalPiece.count)
                               .where(ExternalPiece.job_id == job_id, ExternalPiece.seed.in_(sorted(seeds))))
        for seed, start, count in rows:
            out[seed].append((start, count))
    return out


def _complete_seeds(session: Session, job_id: int, seeds: set[int]) -> set[int]:
    if not seeds:
        return set()
    return set(session.scalars(select(Run.seed).where(Run.job_id == job_id, Run.seed.in_(sorted(seeds)))))


def _episodes(first: int, count: int) -> str:
    return f"episode {first}" if count == 1 else f"episodes {first}-{first + count - 1}"


def _same_as_run(session: Session, job_id: int, piece: Piece) -> bool:
    blob = session.scalar(select(Run.utilities).where(Run.job_id == job_id, Run.seed == piece.seed))
    stored = np.frombuffer(blob, dtype="<f8")[piece.start : piece.start + len(piece.values)]
    return stored.tobytes() == _blob(piece.values)


def _same_as_piece(session: Session, job_id: int, piece: Piece) -> bool:
    blob = session.scalar(select(ExternalPiece.utilities).where(
        ExternalPiece.job_id == job_id, ExternalPiece.seed == piece.seed, ExternalPiece.start == piece.start))
    return blob == _blob(piece.values)


def _promote(session: Session, job: Job, seed: int) -> None:
    """Turn a seed's pieces, which cover every episode, into its run; delete them."""
    of_seed = (ExternalPiece.job_id == job.id, ExternalPiece.seed == seed)
    blobs = session.scalars(select(ExternalPiece.utilities).where(*of_seed).order_by(ExternalPiece.start)).all()
    params = job.config["params"]
    session.add(Run(job_id=job.id, algorithm=job.config["algorithms"][0], seed=seed,
                    episodes=job.config["episodes"], utilities=b"".join(blobs), combined_weights=b"",
                    group_weights=b"", group_shape=[params["n_children"], 0, params["n_types"]]))
    session.execute(delete(ExternalPiece).where(*of_seed))


def append_batch(session: Session, *, job_id: int, key: str, digest: str, pieces: Sequence[Piece],
                 weights: Sequence[tuple[int, np.ndarray]]) -> dict[str, Any]:
    """Store one validated batch of an open run, once; call inside a write transaction.

    ``pieces`` have been checked against the run's definition (seeds declared, episodes within
    range, finite, no overlap among themselves) and ``weights`` shaped ``(n_children, n_types)``.

    Returns:
        ``{"replayed", "values"}`` (values stored by this batch) and the run's state (:func:`progress`).

    Raises:
        NotFound: no such external run.
        Conflict: the key was used for other content, the run is closed, a piece overlaps stored
            episodes with other values, a seed would need more than :data:`MAX_PIECES_PER_SEED` pieces,
            or weights name a seed whose episodes are not all stored yet.
    """
    job = get_external(session, job_id, lock=True)
    known = session.get(ExternalBatch, (job_id, key))
    if known is not None:
        if known.digest != digest:
            raise Conflict(f"batch key {key!r} was already used for a batch of other content in external run "
                           f"{job_id}: a new batch needs a new key")
        return {"replayed": True, "values": known.value_count} | progress(session, job)
    if job.status != OPEN:
        raise Conflict(f"external run {job_id} is {job.status}: it takes no more batches")
    episodes = job.config["episodes"]
    seeds = {p.seed for p in pieces}
    complete = _complete_seeds(session, job_id, seeds | {seed for seed, _ in weights})
    stored = _stored_pieces(session, job_id, seeds - complete)
    rows, touched, added = [], set(), 0
    for i, piece in enumerate(pieces):
        start, count = piece.start, len(piece.values)
        where = f"utilities[{i}]: {_episodes(start, count)} of seed {piece.seed}"
        if piece.seed in complete:
            if _same_as_run(session, job_id, piece):
                continue
            raise Conflict(f"{where} differ from the values already stored (seed {piece.seed} is complete)")
        overlaps = [(s, c) for s, c in stored[piece.seed] if s < start + count and start < s + c]
        if overlaps:
            if overlaps == [(start, count)] and _same_as_piece(session, job_id, piece):
                continue
            s, c = overlaps[0]
            raise Conflict(f"{where} overlap {_episodes(s, c)}, already stored with other values "
                           "(a batch's episodes may be sent again only as they were)")
        if len(stored[piece.seed]) >= MAX_PIECES_PER_SEED:
            raise Conflict(f"{where}: seed {piece.seed} already came in {MAX_PIECES_PER_SEED:,} pieces, the most "
                           "a seed may take: send more episodes per batch")
        stored[piece.seed].append((start, count))
        rows.append({"job_id": job_id, "seed": piece.seed, "start": start, "count": count,
                     "utilities": _blob(piece.values)})
        touched.add(piece.seed)
        added += count
    if rows:
        session.execute(ExternalPiece.__table__.insert(), rows)
    for seed in sorted(touched):
        if sum(c for _, c in stored[seed]) == episodes:
            _promote(session, job, seed)
            complete.add(seed)
    session.flush()
    for i, (seed, values) in enumerate(weights):
        if seed not in complete:
            have = _stored_values(session, job_id, seed)
            raise Conflict(f"weights[{i}]: seed {seed} has {have:,} of its {episodes:,} episodes stored: send a "
                           "seed's final weights once every episode of it is stored (in the same batch or later)")
        session.execute(update(Run).where(Run.job_id == job_id, Run.seed == seed)
                        .values(combined_weights=_blob(values)))
    session.add(ExternalBatch(job_id=job_id, batch_key=key, digest=digest, value_count=added, created_at=utcnow()))
    state = progress(session, job)
    job.progress = state["progress"]
    return {"replayed": False, "values": added} | state


def _stored_values(session: Session, job_id: int, seed: int) -> int:
    return session.scalar(select(func.coalesce(func.sum(ExternalPiece.count), 0)).where(
        ExternalPiece.job_id == job_id, ExternalPiece.seed == seed)) or 0


def progress(session: Session, job: Job) -> dict[str, Any]:
    """``{"status", "progress", "seeds_complete", "values_stored"}`` of an external run."""
    complete = session.scalar(select(func.count()).select_from(Run).where(Run.job_id == job.id)) or 0
    pieces = session.scalar(select(func.coalesce(func.sum(ExternalPiece.count), 0))
                            .where(ExternalPiece.job_id == job.id)) or 0
    episodes = job.config["episodes"]
    total = len(job.config["seeds"]) * episodes
    stored = complete * episodes + int(pieces)
    return {"status": job.status, "progress": stored / total, "seeds_complete": complete, "values_stored": stored}


def state(session: Session, *, job_id: int) -> dict[str, Any]:
    """An external run as ``GET /api/external-runs/{id}`` shows it: the job, and each seed's stored episodes."""
    job = get_external(session, job_id)
    episodes = job.config["episodes"]
    complete = dict(session.execute(select(Run.seed, func.length(Run.combined_weights) > 0)
                                    .where(Run.job_id == job_id)).all())
    partial = dict(session.execute(select(ExternalPiece.seed, func.sum(ExternalPiece.count))
                                   .where(ExternalPiece.job_id == job_id).group_by(ExternalPiece.seed)).all())
    seeds = [{"seed": seed, "episodes_stored": episodes if seed in complete else int(partial.get(seed, 0)),
              "complete": seed in complete, "weights": bool(complete.get(seed, False))}
             for seed in job.config["seeds"]]
    return {"job": job_dict(job), "label": job.config["algorithms"][0], "seeds": seeds} | progress(session, job)


def close_run(session: Session, *, job_id: int) -> Job:
    """Close an open run once every seed's episodes are stored (its summaries with it); a closed run as it is.

    Raises:
        NotFound: no such external run.
        Conflict: a seed's episodes are missing, or some seeds have final weights and others not.
    """
    job = get_external(session, job_id, lock=True)
    if job.status == SUCCEEDED:
        return job
    if job.status != OPEN:
        raise Conflict(f"external run {job_id} is {job.status}: only an open run can be closed")
    run = state(session, job_id=job_id)
    missing = [s for s in run["seeds"] if not s["complete"]]
    if missing:
        listed = ", ".join(f"seed {s['seed']} ({s['episodes_stored']:,} of {job.config['episodes']:,} episodes)"
                           for s in missing[:5])
        more = f" and {len(missing) - 5:,} more" if len(missing) > 5 else ""
        raise Conflict(f"external run {job_id} is incomplete: {len(missing):,} of its {len(run['seeds']):,} seeds "
                       f"lack episodes: {listed}{more}")
    weighted = [s["seed"] for s in run["seeds"] if s["weights"]]
    if weighted and len(weighted) != len(run["seeds"]):
        without = [s["seed"] for s in run["seeds"] if not s["weights"]]
        listed = ", ".join(map(str, without[:5])) + ("..." if len(without) > 5 else "")
        raise Conflict(f"external run {job_id} has final weights for {len(weighted):,} seeds but not for "
                       f"{len(without):,} (seeds {listed}): send every seed's weights or none")
    job.status, job.progress, job.finished_at = SUCCEEDED, 1.0, utcnow()
    session.flush()
    summaries.store(session, job_id)
    return job
