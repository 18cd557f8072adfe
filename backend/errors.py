"""The service's own exceptions; the app maps them to HTTP answers."""

from __future__ import annotations

import re
from collections.abc import Collection, Sequence

from mgrao_core import ConfigError
from mgrao_core.params import PARAMETERS_BY_NAME


class NotFound(Exception):
    """An id that does not exist (404)."""


class Conflict(Exception):
    """A state change the job's status does not allow (409)."""


class Busy(Exception):
    """The answer cannot be computed now: its pool is full, or it waited its longest (503 with ``Retry-After``)."""

    def __init__(self, message: str, retry_after_s: int) -> None:
        super().__init__(message)
        self.retry_after_s = retry_after_s


class BadQuery(Exception):
    """A query parameter that cannot be used, e.g. a malformed cursor (422)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


class InvalidSpec(Exception):
    """The core refused the submitted configuration (422, in docs/api.md's validation shape).

    ``others`` are the other fields it refused at once (a ``ConfigErrors``): every one is answered.
    """

    def __init__(self, loc: list[str | int], field: str, msg: str, others: Sequence[InvalidSpec] = ()) -> None:
        super().__init__(msg)
        self.loc, self.field, self.msg, self.others = loc, field, msg, tuple(others)

    @property
    def every(self) -> tuple[InvalidSpec, ...]:
        """This refusal and the others."""
        return (self, *self.others)

    @classmethod
    def from_config_error(cls, error: ConfigError, *, params: Collection[str] = ()) -> InvalidSpec:
        """Locate a core :class:`ConfigError` in the request body (``params``: the override names), each of several."""
        errors = getattr(error, "errors", None)
        if errors:
            first, *rest = (cls._located(e, params) for e in errors)
            return cls(first.loc, first.field, first.msg, rest)
        return cls._located(error, params)

    @classmethod
    def _located(cls, error: ConfigError, params: Collection[str]) -> InvalidSpec:
        base, *path = re.findall(r"^\w+|\[\d+\]|\.\w+", error.field) or [error.field]
        steps: list[str | int] = [int(p[1:-1]) if p.startswith("[") else p[1:] for p in path]
        match = re.fullmatch(r"(\w+)\[(\d+)\]", error.field)
        loc: list[str | int]
        if (base in params or base in PARAMETERS_BY_NAME) and steps:  # an item of a list parameter, its field
            loc = ["body", "params", base, *steps]
        elif match:
            loc = ["body", match.group(1), int(match.group(2))]
        elif error.field in params or error.field in PARAMETERS_BY_NAME:
            loc = ["body", "params", error.field]
        else:
            loc = ["body", error.field]
        return cls(loc, error.field, str(error))
