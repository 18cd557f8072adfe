"""How a listing of jobs may be ordered: by a column, by any parameter, or by a configuration's result.

``sort`` is one of (each with an optional leading ``-`` for descending):

* ``created_at``, ``name``, ``status``; unnamed jobs (the dashboard's "job 12") come after every named one
  in either direction, by id;
* ``param.NAME`` for any parameter of the schema (``param.learning_rate``);
* ``final_mean:CONFIGURATION``, ``pct_from_uniform:CONFIGURATION``, ``pct_of_max:CONFIGURATION``, a
  configuration's stored summary (``-pct_from_uniform:mgrao-max``).

Jobs without the value (not succeeded, without that configuration, a parameter that is null) come
last in either direction; pages are :mod:`backend.store.keyset` pages.
"""

from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy import ColumnElement, Select, and_

from backend.errors import BadQuery
from backend.store.keyset import Keyset
from backend.store.models import Job, JobSummary
from backend.store.summaries import RESULT_FIELDS
from mgrao_core import ConfigError, parse_algorithm
from mgrao_core.params import PARAMETERS

_COLUMNS = {"created_at": (Job.created_at, "datetime"), "name": (Job.name, "text"), "status": (Job.status, "text")}
_PARAMETERS = {p.name: p for p in PARAMETERS}
SORT_HELP = ("created_at, name, status, param.NAME (any parameter), or a configuration's result: "
             "final_mean:CONFIGURATION, pct_from_uniform:CONFIGURATION, pct_of_max:CONFIGURATION (e.g. "
             "-pct_from_uniform:mgrao-max); a leading '-' sorts descending; jobs without the value come last")
SORT_PATTERN = (f"^-?({'|'.join(_COLUMNS)}|param\\.[^\\x00]+|({'|'.join(RESULT_FIELDS)}):[^\\x00]+)$")
"""The forms :func:`parse_sort` reads, as the OpenAPI document's pattern: what it refuses beyond them is a name
that is no parameter or a label that is no configuration."""
_FORMS = ("created_at, name, status, param.NAME (a parameter), final_mean:CONFIGURATION, "
          "pct_from_uniform:CONFIGURATION or pct_of_max:CONFIGURATION, each with an optional leading '-'")


@dataclass(frozen=True)
class JobOrder(Keyset):
    """A parsed ``sort`` of jobs: a keyset order, and the join a configuration's result needs."""

    configuration: str | None = None  # the summary's configuration, when ordering by a result
    blank_last: bool = False
    """An empty text (a job without a name) comes after every other value, in either direction, by id.

    Each part is read along the column's index (:meth:`parts`): the others (``value <> ''``), then, where a page is
    not full, :meth:`blanks` (``value = ''``, in id order); a page that ends among the blanks has a cursor of key
    ``''``."""

    def valued(self, statement: Select) -> tuple[Select, ColumnElement]:
        """The jobs with the value; a result's are joined to their summary and ordered by its ``job_id``.

        So the summaries' index ``(algorithm, value, job_id)`` reads them in order (docs/service.md, "The runs
        list at a lab's scale").
        """
        if self.configuration is None:
            return super().valued(statement)
        joined = statement.join(JobSummary, and_(JobSummary.job_id == Job.id,
                                                 JobSummary.algorithm == self.configuration))
        return joined.where(self.value.is_not(None)), JobSummary.job_id

    def unvalued(self, statement: Select) -> Select:
        """The jobs without the value: for a result, those without its summary or with the figure null."""
        if self.configuration is not None:
            statement = statement.outerjoin(
                JobSummary, and_(JobSummary.job_id == Job.id, JobSummary.algorithm == self.configuration))
        return super().unvalued(statement)

    def parts(self, statement: Select, cursor: str | None) -> list[Select]:
        """As :meth:`Keyset.parts`; with ``blank_last``, the rows with a non-empty value, then the blanks."""
        if not self.blank_last:
            return super().parts(statement, cursor)
        among_blanks = bool(cursor) and self.decode(cursor)[0] == ""
        parts = [] if among_blanks else [self.apply(statement.where(self.value != ""), cursor)]
        return [*parts, self.blanks(statement, cursor if among_blanks else None)]

    def blanks(self, statement: Select, cursor: str | None = None) -> Select:
        """``statement``'s rows whose value is empty, after ``cursor``'s id, in id order (this order's direction)."""
        statement = statement.where(self.value == "")
        if cursor:
            after = self.decode(cursor)[1]
            statement = statement.where(self.row_id < after if self.descending else self.row_id > after)
        return statement.order_by(self.row_id.desc() if self.descending else self.row_id.asc())


def _order(text: str, descending: bool, value: ColumnElement, kind: str, configuration: str | None = None,
           blank_last: bool = False) -> JobOrder:
    return JobOrder(text, descending, value, kind, Job.id, "job", configuration, blank_last)


def _configuration(label: str) -> str:
    """The canonical label of a configuration (``MGRAO-05:1`` is ``mgrao-5:1``), or BadQuery naming ``sort``."""
    try:
        return parse_algorithm(label, None, field="sort").label
    except ConfigError as error:
        raise BadQuery("sort", error.message) from None


def parse_sort(text: str) -> JobOrder:
    """A ``sort`` query value as an order, or :class:`BadQuery` naming ``sort``."""
    descending = text.startswith("-")
    name = text[1:] if descending else text
    if name in _COLUMNS:
        column, kind = _COLUMNS[name]
        return _order(text, descending, column, kind, blank_last=name == "name")
    if name.startswith("param."):
        parameter = _PARAMETERS.get(name[len("param."):])
        if parameter is None:
            raise BadQuery("sort", f"{name[len('param.'):]!r} is not a parameter (see GET /api/systems)")
        path = Job.config[("params", parameter.name)]
        if parameter.kind in ("int", "float"):
            return _order(text, descending, path.as_float(), "number")
        if parameter.kind == "bool":
            return _order(text, descending, path.as_boolean(), "boolean")
        return _order(text, descending, path.as_string(), "string")
    field, _, label = name.partition(":")
    if field in RESULT_FIELDS:
        if not label:
            raise BadQuery("sort", f"{field} needs a configuration, e.g. {text}:mgrao-max")
        return _order(text, descending, getattr(JobSummary, field), "number", _configuration(label))
    raise BadQuery("sort", f"{text!r} is not an order: use {_FORMS}")
