"""How a listing of jobs may be ordered: by a column, by any parameter, or by a configuration's result.

``sort`` is one of (each with an optional leading ``-`` for descending):

* ``created_at``, ``name``, ``status``;
* ``param.NAME`` for any parameter of the schema (``param.learning_rate``);
* ``final_mean:CONFIGURATION``, ``pct_from_uniform:CONFIGURATION``, ``pct_of_max:CONFIGURATION``, a
  configuration's stored summary (``-pct_from_uniform:mgrao-max``).

Jobs without the value (not succeeded, without that configuration, a parameter that is null) come
last in either direction. Pages are keyset pages over ``(value is null, value, id)``, so that a
cursor stays valid while jobs are added.
"""

from __future__ import annotations

import base64
import json
import math
import re
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import ColumnElement, Select, and_, literal, or_

from backend.errors import BadQuery
from backend.models import Job, JobSummary
from backend.schemas import MAX_JOB_ID
from backend.summaries import RESULT_FIELDS
from mgrao_core import ConfigError, parse_algorithm
from mgrao_core.params import PARAMETERS

_COLUMNS = {"created_at": (Job.created_at, "datetime"), "name": (Job.name, "text"), "status": (Job.status, "text")}
_PARAMETERS = {p.name: p for p in PARAMETERS}
SORT_HELP = ("created_at, name, status, param.NAME (any parameter), or a configuration's result: "
             "final_mean:CONFIGURATION, pct_from_uniform:CONFIGURATION, pct_of_max:CONFIGURATION (e.g. "
             "-pct_from_uniform:mgrao-max); a leading '-' sorts descending; jobs without the value come last")
_FORMS = ("created_at, name, status, param.NAME (a parameter), final_mean:CONFIGURATION, "
          "pct_from_uniform:CONFIGURATION or pct_of_max:CONFIGURATION, each with an optional leading '-'")


@dataclass(frozen=True)
class JobOrder:
    """A parsed ``sort``: the value ordered by, its kind (for the cursor), the join it needs."""

    text: str
    descending: bool
    value: ColumnElement
    kind: str  # "datetime" or "text" (columns, never null); "string", "number" or "boolean" (may be null)
    configuration: str | None = None  # the summary's configuration, when ordering by a result

    def apply(self, statement: Select, cursor: str | None) -> Select:
        """``statement`` (a select of jobs) joined as needed, after ``cursor``, ordered."""
        if self.configuration is not None:
            statement = statement.outerjoin(
                JobSummary, and_(JobSummary.job_id == Job.id, JobSummary.algorithm == self.configuration))
        if cursor:
            key, after = self.decode(cursor)
            bound = literal(key, type_=self.value.type)  # a parameter, so that booleans compare with < and >
            beyond = (lambda a, b: a < b) if self.descending else (lambda a, b: a > b)
            if key is None:
                statement = statement.where(self.value.is_(None), beyond(Job.id, after))
            else:
                statement = statement.where(or_(
                    and_(self.value.is_not(None),
                         or_(beyond(self.value, bound), and_(self.value == bound, beyond(Job.id, after)))),
                    self.value.is_(None),
                ))
        direction = (self.value.desc(), Job.id.desc()) if self.descending else (self.value.asc(), Job.id.asc())
        return statement.order_by(self.value.is_(None), *direction)

    def encode(self, key: Any, job_id: int) -> str:
        """An opaque cursor after the row ``(key, job_id)``."""
        if isinstance(key, datetime):
            key = key.isoformat()
        raw = json.dumps([self.text, key, job_id], separators=(",", ":")).encode()
        return base64.urlsafe_b64encode(raw).decode().rstrip("=")

    def decode(self, cursor: str) -> tuple[Any, int]:
        """The ``(key, id)`` a cursor points after, or :class:`BadQuery` naming ``cursor``."""
        try:
            raw = base64.urlsafe_b64decode(cursor + "=" * (-len(cursor) % 4))
            text, key, job_id = json.loads(raw)
            if text != self.text or isinstance(job_id, bool) or not isinstance(job_id, int):
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
            raise BadQuery("cursor", "is not a cursor of this listing (use next_cursor as given, same sort)") from None
        if not 1 <= job_id <= MAX_JOB_ID:
            raise BadQuery("cursor", f"its job id must be in [1, {MAX_JOB_ID}] (got {job_id})")
        return key, job_id


def _key_fits(kind: str, key: Any) -> bool:
    if key is None:
        return kind in ("string", "number", "boolean")
    if kind in ("datetime", "text", "string"):
        return isinstance(key, str)
    if kind == "boolean":
        return isinstance(key, bool) or key in (0, 1)  # SQLite reads a JSON boolean as 0 or 1
    return isinstance(key, int | float) and not isinstance(key, bool)


def _configuration(label: str) -> str:
    """The canonical label of a configuration (``MGRAO-05:1`` is ``mgrao-5:1``), or BadQuery naming ``sort``."""
    match = re.fullmatch(r"mgrao-0*(\d{1,6}):\d{1,6}", label.strip().lower())
    groups = int(match.group(1)) if match and int(match.group(1)) > 0 else 1
    try:
        return parse_algorithm(label, n_parents=groups, field="sort").label
    except ConfigError as error:
        raise BadQuery("sort", error.message) from None


def parse_sort(text: str) -> JobOrder:
    """A ``sort`` query value as an order, or :class:`BadQuery` naming ``sort``."""
    descending = text.startswith("-")
    name = text[1:] if descending else text
    if name in _COLUMNS:
        column, kind = _COLUMNS[name]
        return JobOrder(text, descending, column, kind)
    if name.startswith("param."):
        parameter = _PARAMETERS.get(name[len("param."):])
        if parameter is None:
            raise BadQuery("sort", f"{name[len('param.'):]!r} is not a parameter (see GET /api/systems)")
        path = Job.config[("params", parameter.name)]
        if parameter.kind in ("int", "float"):
            return JobOrder(text, descending, path.as_float(), "number")
        if parameter.kind == "bool":
            return JobOrder(text, descending, path.as_boolean(), "boolean")
        return JobOrder(text, descending, path.as_string(), "string")
    field, _, label = name.partition(":")
    if field in RESULT_FIELDS:
        if not label:
            raise BadQuery("sort", f"{field} needs a configuration, e.g. {text}:mgrao-max")
        return JobOrder(text, descending, getattr(JobSummary, field), "number", _configuration(label))
    raise BadQuery("sort", f"{text!r} is not an order: use {_FORMS}")
