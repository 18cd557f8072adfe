"""Runs logged from outside: an opening's definition and a batch's content, checked before anything is stored.

What depends on nothing stored is refused here with 422 naming the field (``InvalidSpec``): a label that
is a built-in algorithm's, a system and parameters the core refuses (``make_params``, exactly as for a
job), repeated seeds, the stored-bytes budget of a job (``MAX_RESULT_BYTES``), a piece's seed that the
run did not declare or episodes beyond its count, two pieces of one batch that overlap, weights of
the wrong shape. What depends on what is stored (a conflict, 409) is :mod:`backend.store.external`'s.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np
import orjson

from backend.errors import InvalidSpec
from backend.store.external import Piece
from mgrao_core import MAX_RESULT_BYTES, ConfigError, make_params
from mgrao_core.algorithms import parse_algorithm
from mgrao_core.presets import get_preset

_F = 8  # bytes of a stored float64


class RunDefinition(Protocol):
    """An opening's definition as the API has parsed it (``POST /api/external-runs``)."""

    label: str
    system: str
    params: dict[str, Any]
    seeds: int | list[int]
    episodes: int


class UtilityPiece(Protocol):
    """Consecutive episode utilities of one seed, from episode ``start``."""

    seed: int
    start: int
    values: list[float]


class SeedWeights(Protocol):
    """A seed's final weights, a row per child."""

    seed: int
    weights: list[list[float]]


class Batch(Protocol):
    """A batch as the API has parsed it (``POST /api/external-runs/{id}/batches``)."""

    utilities: Sequence[UtilityPiece]
    weights: Sequence[SeedWeights]

    def model_dump(self, *, mode: str, exclude: set[str]) -> dict[str, Any]:
        """Its content as JSON-ready data (what the digest is taken of)."""
        ...


def check_label(label: str) -> None:
    """Refuse (422 naming ``label``) a label the core reads as a built-in algorithm's.

    The schema's pattern has already checked its characters and length.
    """
    try:
        algorithm = parse_algorithm(label, None)
    except ConfigError:
        return
    raise InvalidSpec(["body", "label"], "label",
                      f"label: {label!r} is the built-in algorithm {algorithm.label!r} (GET /api/algorithms): an "
                      "external run needs a label of its own, e.g. 'my-learner'")


def external_config(body: RunDefinition) -> dict[str, Any]:
    """The job configuration of an external run: a simulated job's, with the label as its one algorithm.

    The system and parameters go through the core's ``make_params`` on the preset's, as a job's do, so
    that the run's ``config_hash`` is a built-in job's of the same world.
    """
    check_label(body.label)
    try:
        params = make_params(body.params, base=get_preset(body.system).params)
    except ConfigError as error:
        raise InvalidSpec.from_config_error(error, params=body.params) from None
    if isinstance(body.seeds, int):
        seeds = list(range(body.seeds))
    else:
        seeds = list(body.seeds)
        seen: dict[int, int] = {}
        for i, seed in enumerate(seeds):
            if seed in seen:
                raise InvalidSpec(["body", "seeds", i], f"seeds[{i}]",
                                  f"seeds[{i}]: repeats seeds[{seen[seed]}] ({seed}): a run's seeds are distinct")
            seen[seed] = i
    stored = _F * len(seeds) * (body.episodes + params.n_children * params.n_types)
    if stored > MAX_RESULT_BYTES:
        raise InvalidSpec(["body", "results"], "results",
                          f"results: the run's utilities and weights would take {stored / 1024**2:,.0f} MiB, over "
                          f"the limit of {MAX_RESULT_BYTES // 1024**2:,} MiB per experiment (fewer seeds or episodes)")
    return {"system": body.system, "params": params.as_config(), "algorithms": [body.label], "seeds": seeds,
            "episodes": body.episodes}


def batch_content(body: Batch, config: dict[str, Any]) -> tuple[str, list[Piece], list[tuple[int, Any]]]:
    """A batch's digest, pieces and weights, checked against the run's definition ``config``.

    Raises:
        InvalidSpec: naming ``utilities[i]`` or ``weights[i]``: a seed the run does not declare, episodes
            past the run's count, pieces of one batch that overlap, weights of another shape than
            ``(n_children, n_types)``, or a seed's weights twice.
    """
    seeds = set(config["seeds"])
    episodes = config["episodes"]
    shape = (config["params"]["n_children"], config["params"]["n_types"])
    pieces: list[Piece] = []
    spans: dict[int, list[tuple[int, int, int]]] = {}
    for i, entry in enumerate(body.utilities):
        field = f"utilities[{i}]"
        if entry.seed not in seeds:
            raise InvalidSpec(["body", "utilities", i, "seed"], field, f"{field}: seed {entry.seed} is not one of the "
                              f"run's {len(seeds):,} seeds ({_some(config['seeds'])})")
        end = entry.start + len(entry.values)
        if end > episodes:
            raise InvalidSpec(["body", "utilities", i, "values"], field,
                              f"{field}: episodes {entry.start}-{end - 1} go past the run's {episodes:,} episodes "
                              f"(episodes are counted from 0: the last is {episodes - 1:,})")
        for j, start, stop in spans.get(entry.seed, []):
            if start < end and entry.start < stop:
                raise InvalidSpec(["body", "utilities", i], field, f"{field}: episodes {entry.start}-{end - 1} of seed "
                                  f"{entry.seed} overlap utilities[{j}] of the same batch")
        spans.setdefault(entry.seed, []).append((i, entry.start, end))
        pieces.append(Piece(entry.seed, entry.start, np.asarray(entry.values, dtype="<f8")))
    weights: list[tuple[int, Any]] = []
    weighted: dict[int, int] = {}
    for i, entry in enumerate(body.weights):
        field = f"weights[{i}]"
        if entry.seed not in seeds:
            raise InvalidSpec(["body", "weights", i, "seed"], field, f"{field}: seed {entry.seed} is not one of the "
                              f"run's {len(seeds):,} seeds ({_some(config['seeds'])})")
        if entry.seed in weighted:
            raise InvalidSpec(["body", "weights", i, "seed"], field,
                              f"{field}: repeats weights[{weighted[entry.seed]}] (seed {entry.seed})")
        weighted[entry.seed] = i
        rows = entry.weights
        if len(rows) != shape[0] or any(len(row) != shape[1] for row in rows):
            got = f"{len(rows)} rows of {sorted({len(r) for r in rows})} values"
            raise InvalidSpec(["body", "weights", i, "weights"], field,
                              f"{field}: must be {shape[0]} rows (one per child) of {shape[1]} values (one per type), "
                              f"got {got}")
        weights.append((entry.seed, np.asarray(rows, dtype="<f8")))
    content = orjson.dumps(body.model_dump(mode="json", exclude={"key"}))
    return hashlib.sha256(content).hexdigest(), pieces, weights


def _some(seeds: list[int]) -> str:
    return ", ".join(map(str, seeds[:5])) + (", ..." if len(seeds) > 5 else "")
