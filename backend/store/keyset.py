"""Keyset pages of a listing: an order over one value and the row id, and the cursor after a row.

A listing is ordered by ``(value is null, value, id)``, ascending or descending, so rows without the
value come last in either direction; the cursor of a page holds the sort it was made for, the last
row's value and its id (opaque to clients: base64 of JSON), so a cursor stays valid while rows are
added, and a cursor made for another sort, or crafted, answers 422 naming ``cursor``.
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import ColumnElement, Select, and_, literal, or_, tuple_

from backend.errors import BadQuery
from backend.store.models import MAX_JOB_ID, has_nul

NEVER_NULL = frozenset({"datetime", "text"})
"""Kinds of value that are columns declared NOT NULL."""
NOT_A_CURSOR = "is not a cursor of this listing (use next_cursor as given, same sort)"


@dataclass(frozen=True)
class Keyset:
    """A sort (``text`` as the client gave it) over ``value``, then ``row_id``; ``noun`` names the rows."""

    text: str
    descending: bool
    value: ColumnElement
    kind: str  # "datetime" or "text" (columns, never null); "string", "number" or "boolean" (may be null)
    row_id: ColumnElement
    noun: str

    @property
    def nullable(self) -> bool:
        """Whether the value may be null (a parameter or a result); columns (datetime, text) never are."""
        return self.kind not in NEVER_NULL

    def apply(self, statement: Select, cursor: str | None) -> Select:
        """``statement`` after ``cursor`` (if any), ordered.

        A value that is never null is ordered by ``(value, id)`` alone, and a cursor on it is one
        row-value comparison: an index on ``(value, id)`` then reads the page and stops, where the
        null-first term would make the database sort every matching row for each page.
        """
        beyond = (lambda a, b: a < b) if self.descending else (lambda a, b: a > b)
        direction = ((self.value.desc(), self.row_id.desc()) if self.descending
                     else (self.value.asc(), self.row_id.asc()))
        if not self.nullable:
            if cursor:
                key, after = self.decode(cursor)
                statement = statement.where(
                    beyond(tuple_(self.value, self.row_id), tuple_(literal(key, type_=self.value.type), after)))
            return statement.order_by(*direction)
        if cursor:
            key, after = self.decode(cursor)
            bound = literal(key, type_=self.value.type)  # a parameter, so that booleans compare with < and >
            if key is None:
                statement = statement.where(self.value.is_(None), beyond(self.row_id, after))
            else:
                statement = statement.where(or_(
                    and_(self.value.is_not(None),
                         or_(beyond(self.value, bound), and_(self.value == bound, beyond(self.row_id, after)))),
                    self.value.is_(None),
                ))
        return statement.order_by(self.value.is_(None), *direction)

    def encode(self, key: Any, row_id: int) -> str:
        """An opaque cursor after the row ``(key, row_id)``."""
        if isinstance(key, datetime):
            key = key.isoformat()
        raw = json.dumps([self.text, key, row_id], separators=(",", ":")).encode()
        return base64.urlsafe_b64encode(raw).decode().rstrip("=")

    def decode(self, cursor: str) -> tuple[Any, int]:
        """The ``(key, id)`` a cursor points after, or :class:`BadQuery` naming ``cursor``."""
        try:
            raw = base64.urlsafe_b64decode(cursor + "=" * (-len(cursor) % 4))
            text, key, row_id = json.loads(raw)
            if text != self.text or isinstance(row_id, bool) or not isinstance(row_id, int):
                raise ValueError
            if not _key_fits(self.kind, key):
                raise ValueError
            if self.kind == "datetime":
                key = datetime.fromisoformat(key)
            elif self.kind == "number" and key is not None:
                key = float(key)  # a float the database can compare (an int past 2^63 could not be bound)
                if not math.isfinite(key):
                    raise ValueError
            elif self.kind == "boolean" and key is not None:
                key = bool(key)
        except (ValueError, TypeError, UnicodeDecodeError, OverflowError):
            raise BadQuery("cursor", NOT_A_CURSOR) from None
        if not 1 <= row_id <= MAX_JOB_ID:
            raise BadQuery("cursor", f"its {self.noun} id must be in [1, {MAX_JOB_ID}] (got {row_id})")
        return key, row_id


def _key_fits(kind: str, key: Any) -> bool:
    if key is None:
        return kind in ("string", "number", "boolean")
    if kind in ("datetime", "text", "string"):
        return isinstance(key, str) and not has_nul(key)  # a NUL: no stored text has one, PostgreSQL refuses it
    if kind == "boolean":
        return isinstance(key, bool) or key in (0, 1)  # SQLite reads a JSON boolean as 0 or 1
    return isinstance(key, int | float) and not isinstance(key, bool)
