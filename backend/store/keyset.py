"""Keyset pages of a listing: an order over one value and the row id, and the cursor after a row.

A listing is ordered by ``(value is null, value, id)``, ascending or descending, so rows without the
value come last in either direction (where the value may be null, read in two parts: :meth:`Keyset.parts`);
the cursor of a page holds the sort it was made for, the last row's value and its id (opaque to clients:
base64 of JSON), so a cursor stays valid while rows are added, and a cursor made for another sort, or
crafted, answers 422 naming ``cursor``.
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import ColumnElement, Select, literal, tuple_

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
        """``statement`` after ``cursor`` (if any), ordered: an order whose value is never null.

        It is ordered by ``(value, id)`` alone, and a cursor on it is one row-value comparison: an index on
        ``(value, id)`` then reads the page and stops. An order whose value may be null is read in
        :meth:`parts`.
        """
        if self.nullable:
            raise ValueError(f"{self.text}: a value that may be null is read in parts (Keyset.parts)")
        if cursor:
            key, after = self.decode(cursor)
            statement = statement.where(
                self._beyond(tuple_(self.value, self.row_id), tuple_(literal(key, type_=self.value.type), after)))
        return statement.order_by(*self._direction(self.value, self.row_id))

    def parts(self, statement: Select, cursor: str | None) -> list[Select]:
        """The statements whose rows, one after the other, are the listing after ``cursor``, each ordered.

        An order whose value is never null is one statement (:meth:`apply`). Otherwise the rows with the value
        come first, ordered by ``(value, id)`` (:meth:`valued`: an index on the value reads them in order and the
        page stops), then the rows without it, ordered by id (:meth:`unvalued`): the order of
        ``(value is null, value, id)`` in one statement, which made the database sort every matching row for
        each page. A cursor in the first part goes on into the second; one in the second stays there.
        """
        if not self.nullable:
            return [self.apply(statement, cursor)]
        key, after = self.decode(cursor) if cursor else (None, None)
        parts = []
        if cursor is None or key is not None:
            valued, tie = self.valued(statement)
            if cursor:
                bound = literal(key, type_=self.value.type)  # a parameter, so that booleans compare with < and >
                valued = valued.where(self._beyond(tuple_(self.value, tie), tuple_(bound, after)))
            parts.append(valued.order_by(*self._direction(self.value, tie)))
            cursor = None
        unvalued = self.unvalued(statement)
        if cursor:
            unvalued = unvalued.where(self._beyond(self.row_id, after))
        parts.append(unvalued.order_by(*self._direction(self.row_id)))
        return parts

    def valued(self, statement: Select) -> tuple[Select, ColumnElement]:
        """``statement``'s rows that have the value, and the column of their ids to order them by."""
        return statement.where(self.value.is_not(None)), self.row_id

    def unvalued(self, statement: Select) -> Select:
        """``statement``'s rows without the value."""
        return statement.where(self.value.is_(None))

    def _beyond(self, a: Any, b: Any) -> ColumnElement:
        return a < b if self.descending else a > b

    def _direction(self, *columns: ColumnElement) -> tuple[ColumnElement, ...]:
        return tuple(c.desc() if self.descending else c.asc() for c in columns)

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
