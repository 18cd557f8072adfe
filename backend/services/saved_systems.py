"""Saved systems (issue 20, "Your own system"): a named base preset plus overrides, used like a preset.

A job, a study's trial or a comparison of a saved system runs its base preset with the saved overrides
(the request's own ``params`` on top): the job's stored configuration is the base preset's, so its world
and its ``config_hash`` are those of the same preset-with-overrides job, and its tags record the saved
name (``system:<name>``). The definition is the JSON file ``mgrao systems export`` writes and
``POST /api/systems/saved`` takes: ``{"name", "description", "base", "params"}``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from typing import Any

from sqlalchemy import select
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from backend.errors import Conflict, InvalidSpec, NotFound
from backend.store.models import SAVED_SYSTEM_TAG_PREFIX, SavedSystem, utcnow
from mgrao_core import PRESETS, ConfigError, make_params
from mgrao_core.algorithms import valid_labels

NAME_PATTERN = "^[a-z][a-z0-9-]{0,31}$"
"""A saved system's name: 1-32 characters, a lowercase letter then lowercase letters, digits or ``-``."""
TAG_PREFIX = SAVED_SYSTEM_TAG_PREFIX
"""The tag a job of a saved system carries: ``system:<name>``."""


def tag(name: str) -> str:
    """The tag a job of the saved system ``name`` carries."""
    return f"{TAG_PREFIX}{name}"


def tagged(tags: Sequence[str] | None) -> list[str]:
    """The saved systems that ``tags`` name, in their order (a job carries at most one)."""
    return [t.removeprefix(TAG_PREFIX) for t in tags or () if t.startswith(TAG_PREFIX)]


def check_name(name: str) -> str:
    """``name`` if it can name a saved system (:data:`NAME_PATTERN`, and no preset's name)."""
    if not re.fullmatch(NAME_PATTERN, name):
        raise InvalidSpec(["body", "name"], "name", "name: must be 1-32 characters, a lowercase letter then "
                                                    f"lowercase letters, digits or '-' (got {name[:40]!r})")
    if name in PRESETS:
        raise InvalidSpec(["body", "name"], "name", f"name: {name!r} is a preset's name: choose another")
    return name


def checked_params(base: str, params: Mapping[str, Any]) -> dict[str, Any]:
    """The overrides validated on the base preset (``make_params``), as plain JSON values."""
    if base not in PRESETS:
        raise InvalidSpec(["body", "base"], "base", f"base: must be one of {', '.join(PRESETS)} (got {base!r})")
    try:
        resolved = make_params(params, base=PRESETS[base].params).as_dict()
    except ConfigError as error:
        raise InvalidSpec.from_config_error(error, params=params) from None
    return {name: resolved[name] for name in params}


def saved_dict(saved: SavedSystem) -> dict[str, Any]:
    """A saved system as the API shows it: its definition, the resolved parameters and its default configurations.

    Those are the base's that are valid for it: ``large30`` (large with 30 parents) leaves out ``mgrao-25:1``,
    whose 25 groups do not divide its parents, so that a form filled with them can be run as it is.
    """
    preset = PRESETS.get(saved.base)
    resolved = make_params(saved.params, base=preset.params).as_dict() if preset else {}
    return {"name": saved.name, "description": saved.description, "base": saved.base, "params": saved.params,
            "resolved": resolved,
            "algorithms": list(valid_labels(preset.algorithms, resolved["n_parents"])) if preset else []}


def definition(saved: SavedSystem) -> dict[str, Any]:
    """The saved system's file: what ``POST /api/systems/saved`` takes back."""
    return {"name": saved.name, "description": saved.description, "base": saved.base, "params": saved.params}


def list_saved(session: Session) -> list[SavedSystem]:
    """Every saved system, by name."""
    return list(session.scalars(select(SavedSystem).order_by(SavedSystem.name)))


def get_saved(session: Session, *, name: str) -> SavedSystem:
    """The saved system ``name``, or :class:`NotFound`."""
    saved = session.scalar(select(SavedSystem).where(SavedSystem.name == name))
    if saved is None:
        raise NotFound(f"saved system {name!r} not found")
    return saved


def create_saved(session: Session, *, name: str, description: str, base: str, params: Mapping[str, Any]) -> SavedSystem:
    """Save a new system (:class:`Conflict` if the name is taken)."""
    saved = SavedSystem(name=check_name(name), description=description, base=base,
                        params=checked_params(base, params), created_at=utcnow(), updated_at=utcnow())
    if session.scalar(select(SavedSystem.id).where(SavedSystem.name == name)) is not None:
        raise Conflict(f"a saved system is already called {name!r}: give this one another name, or replace that one")
    session.add(saved)
    try:
        session.flush()
    except IntegrityError:  # saved at the same moment by another request
        raise Conflict(f"a saved system is already called {name!r}: give this one another name, or replace that "
                       "one") from None
    return saved


def replace_saved(session: Session, *, name: str, description: str, base: str,
                  params: Mapping[str, Any]) -> SavedSystem:
    """Replace the definition of the saved system ``name`` (jobs already run keep theirs)."""
    saved = get_saved(session, name=name)
    saved.params = checked_params(base, params)
    saved.base, saved.description, saved.updated_at = base, description, utcnow()
    return saved


def delete_saved(session: Session, *, name: str) -> None:
    """Forget the saved system ``name`` (its jobs stay, with their tag)."""
    session.delete(get_saved(session, name=name))


def resolve(session: Session, system: str, params: Mapping[str, Any],
            where: list[str | int] | None = None) -> tuple[str, dict[str, Any], str | None]:
    """A request's ``system`` and ``params`` as a preset and overrides, and the saved name (None for a preset).

    A saved system's overrides come first, the request's on top; an unknown name answers 422 at ``where``.
    """
    if system in PRESETS:
        return system, dict(params), None
    saved = session.scalar(select(SavedSystem).where(SavedSystem.name == system))
    if saved is None:
        loc = where or ["body", "system"]
        field = ".".join(str(p) for p in loc[1:])
        raise InvalidSpec(loc, field, f"{field}: unknown system {system!r}: use one of {', '.join(PRESETS)} or a "
                                      "saved system (GET /api/systems/saved)")
    return saved.base, dict(saved.params) | dict(params), saved.name
