"""The detail of a refused request: docs/api.md's ``{"loc", "field", "msg", "type"}``, one per field.

The app answers 422 with it, and ``POST /api/jobs/check`` returns the very detail a submission would get.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any


def validation_detail(loc: list[str | int], field: str, msg: str) -> dict[str, Any]:
    """One detail of a value refused by a rule of ours: where it is, the field, and what is wrong."""
    return {"loc": loc, "field": field, "msg": msg, "type": "value_error"}


def validation_details(errors: Sequence[Any], body: Any = None) -> list[dict[str, Any]]:
    """Pydantic errors as docs/api.md's ``{"loc", "field", "msg", "type"}``, one per field.

    Union branches (seeds as a count or a list, parameter values) are folded into the field, and a
    bad key of an object (``params``) is named by the object; of several errors on a field, a rule of
    ours beats a limit, which beats a type mismatch. Inside an object of the ``body`` other than a
    job's ``params`` (a study's ``base``, ``space``, ``objective``) the location follows the body all
    the way down and the field is named as the core names it (``space.learning_rate.values[2]``).
    """
    best: dict[tuple, dict[str, Any]] = {}
    loc: list[str | int]
    if any(item.get("type") != "none_required" for item in errors):  # "or null" branches say nothing more
        errors = [item for item in errors if item.get("type") != "none_required"]
    for item in errors:
        raw = list(item.get("loc", ()))
        if "[key]" in raw:  # a key of an object: named by the object (the key itself may be unprintable)
            raw = raw[: raw.index("[key]") - 1]
        nested = (len(raw) > 2 and raw[0] == "body" and raw[1] != "params" and isinstance(body, dict)
                  and isinstance(body.get(raw[1]), dict))
        if item.get("type") == "json_invalid":
            loc, field = ["body"], "body"
        elif nested:
            path = _body_path(body, raw[1:], missing=item.get("type") == "missing")
            loc = ["body", *path]
            field = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in path).lstrip(".")
        elif len(raw) < 2:
            loc = raw or ["body"]
            field = str(loc[-1])
        elif raw[1] == "params" and len(raw) > 2:
            loc, field = raw[:3], str(raw[2])
        else:
            index = next((p for p in raw[2:] if isinstance(p, int)), None)
            loc = raw[:2] + ([index] if index is not None else [])
            field = str(raw[1]) if index is None else f"{raw[1]}[{index}]"
        key = tuple(loc if nested else loc[:3] if len(raw) > 1 and raw[1] == "params" else loc[:2])
        kind = str(item.get("type", "value_error"))
        entry = {"loc": loc, "field": field, "msg": f"{field}: {item.get('msg', 'invalid')}", "type": kind}
        if key not in best or _rank(kind) > _rank(best[key]["type"]):
            best[key] = entry
    return list(best.values())


def _rank(kind: str) -> int:
    """Which of several errors on one field to show: a rule of ours (NUL), then a limit, then a type mismatch."""
    if kind == "value_error":
        return 2
    return 0 if kind.endswith(("_type", "_parsing")) else 1


def _body_path(body: Any, parts: Sequence[str | int], *, missing: bool) -> list[str | int]:
    """The part of an error's location that is in the body (a union's branch names are not), plus a missing key."""
    path: list[str | int] = []
    node = body
    for part in parts:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and isinstance(part, int) and 0 <= part < len(node):
            node = node[part]
        elif missing and part == parts[-1] and isinstance(node, dict):
            pass  # the required key that is not there
        else:
            continue
        path.append(part)
    return path
