"""The detail of a refused request: docs/api.md's ``{"loc", "field", "msg", "type"}``, one per field.

The app answers 422 with it, and ``POST /api/jobs/check`` returns the very detail a submission would get. The
schema's refusals are said in the product's words (:func:`in_our_words`: "must have at least 1 item", "must
start with a lowercase letter, ..."), not the validation library's.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

PATTERN_WORDS: dict[str, str] = {
    "^[a-z][a-z0-9-]{0,31}$": "must be 1-32 characters: a lowercase letter, then lowercase letters, digits or '-'",
    "^[a-z][a-z0-9._-]{0,31}$": "must be 1-32 characters: a lowercase letter, then lowercase letters, digits, '.', "
                                "'_' or '-'",
    "^[A-Za-z0-9._:-]{1,64}$": "must be 1-64 characters: letters, digits, '.', '_', ':' or '-'",
    "^[0-9a-f]*$": "must be lowercase hexadecimal digits (a token the server gave)",
}
"""What each pattern of the API's schema asks for, in words (the saved systems' names, runs' labels, keys)."""


def _got(value: Any) -> str:
    if isinstance(value, str) and re.fullmatch(r"-?[0-9]+(\.[0-9]+)?", value):  # a query parameter's number
        return f" (got {value})"
    if isinstance(value, str):
        return f" (got {value[:40]!r}{'...' if len(value) > 40 else ''})"
    if isinstance(value, bool) or value is None:
        return f" (got {'true' if value is True else 'false' if value is False else 'null'})"
    if isinstance(value, int | float):
        return f" (got {value:g})" if isinstance(value, float) else f" (got {value})"
    return f" (got {type(value).__name__})"


def in_our_words(item: dict[str, Any]) -> str:
    """A validation error's message in the product's words (the library's where there are none)."""
    kind, ctx, value = item.get("type", ""), item.get("ctx") or {}, item.get("input")
    plural = "s" if ctx.get("min_length", ctx.get("max_length")) != 1 else ""
    count = f" (got {ctx['actual_length']})" if ctx.get("actual_length") is not None else ""
    words = {
        "greater_than_equal": lambda: f"must be at least {ctx.get('ge')}{_got(value)}",
        "greater_than": lambda: f"must be more than {ctx.get('gt')}{_got(value)}",
        "less_than_equal": lambda: f"must be at most {ctx.get('le')}{_got(value)}",
        "less_than": lambda: f"must be less than {ctx.get('lt')}{_got(value)}",
        "int_type": lambda: f"must be a whole number{_got(value)}",
        "int_parsing": lambda: f"must be a whole number{_got(value)}",
        "int_from_float": lambda: f"must be a whole number{_got(value)}",
        "float_type": lambda: f"must be a number{_got(value)}",
        "float_parsing": lambda: f"must be a number{_got(value)}",
        "finite_number": lambda: "must be a finite number",
        "bool_type": lambda: f"must be true or false{_got(value)}",
        "bool_parsing": lambda: f"must be true or false{_got(value)}",
        "string_type": lambda: f"must be text{_got(value)}",
        "list_type": lambda: f"must be a list{_got(value)}",
        "dict_type": lambda: f"must be an object{_got(value)}",
        "model_type": lambda: f"must be an object{_got(value)}",
        "model_attributes_type": lambda: f"must be an object{_got(value)}",
        "too_short": lambda: f"must have at least {ctx.get('min_length')} item{plural}{count}",
        "too_long": lambda: f"must have at most {ctx.get('max_length')} item{plural}{count}",
        "string_too_short": lambda: ("must not be empty" if ctx.get("min_length") == 1
                                     else f"must be at least {ctx.get('min_length')} characters"),
        "string_too_long": lambda: f"must be at most {ctx.get('max_length')} characters"
                                   + (f" (got {len(value)})" if isinstance(value, str) else ""),
        "string_pattern_mismatch": lambda: PATTERN_WORDS.get(str(ctx.get("pattern")),
                                                             f"must match the pattern {ctx.get('pattern')}"),
        "missing": lambda: "is required",
        "extra_forbidden": lambda: "is not a field of this body",
        "literal_error": lambda: f"must be one of {ctx.get('expected')}{_got(value)}",
        "enum": lambda: f"must be one of {ctx.get('expected')}{_got(value)}",
        "json_invalid": lambda: "is not valid JSON",
        "url_parsing": lambda: "must be a URL",
    }
    say = words.get(kind)
    return say() if say else str(item.get("msg", "invalid"))


def validation_detail(loc: list[str | int], field: str, msg: str) -> dict[str, Any]:
    """One detail of a value refused by a rule of ours: where it is, the field, and what is wrong."""
    return {"loc": loc, "field": field, "msg": msg, "type": "value_error"}


def validation_details(errors: Sequence[Any], body: Any = None) -> list[dict[str, Any]]:
    """Pydantic errors as docs/api.md's ``{"loc", "field", "msg", "type"}``, one per field.

    Union branches (seeds as a count or a list, parameter values) are folded into the field, and a
    bad key of an object (``params``) is named by the object; of several errors on a field, a rule of
    ours beats a limit, which beats a type mismatch, and of equal rank the one deeper in the value. Inside
    an object of the ``body`` other than a job's ``params`` (a study's ``base``, ``space``, ``objective``;
    an item of a list: a batch's ``jobs[0]``, ``utilities[1]``) the location follows the body all the way
    down and the field is named as the core names it (``space.learning_rate.values[2]``, ``jobs[0].episodes``).
    """
    best: dict[tuple, dict[str, Any]] = {}
    loc: list[str | int]
    if any(item.get("type") != "none_required" for item in errors):  # "or null" branches say nothing more
        errors = [item for item in errors if item.get("type") != "none_required"]
    for item in errors:
        raw = list(item.get("loc", ()))
        if "[key]" in raw:  # a key of an object: named by the object (the key itself may be unprintable)
            raw = raw[: raw.index("[key]") - 1]
        nested = len(raw) > 2 and raw[0] == "body" and raw[1] != "params" and _is_object(body, raw[1:3])
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
        # one error per field: a list's items fold into it (values[0] .. values[4999] out of range: one error)
        key = tuple(_field_of(loc) if nested else loc[:3] if len(raw) > 1 and raw[1] == "params" else loc[:2])
        kind = str(item.get("type", "value_error"))
        entry = {"loc": loc, "field": field, "msg": f"{field}: {in_our_words(item)}", "type": kind}
        if key not in best or (_rank(kind), len(loc)) > (_rank(best[key]["type"]), len(best[key]["loc"])):
            best[key] = entry  # of equal rank the deeper: [1, "x"] fails seeds[1], not "seeds: not a whole number"
    return list(best.values())


def _field_of(loc: list[str | int]) -> list[str | int]:
    """A location without its trailing list indices (``weights[0].weights[3][7]``: ``weights[0].weights``)."""
    end = len(loc)
    while end > 1 and isinstance(loc[end - 1], int):
        end -= 1
    return loc[:end]


def _is_object(body: Any, parts: Sequence[str | int]) -> bool:
    """Whether the body holds an object at ``parts`` (``["base"]``, or ``["jobs", 0]``: an object of a list)."""
    node = body.get(parts[0]) if isinstance(body, dict) else None
    if isinstance(node, list) and len(parts) > 1 and isinstance(parts[1], int) and 0 <= parts[1] < len(node):
        node = node[parts[1]]
    return isinstance(node, dict)


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
