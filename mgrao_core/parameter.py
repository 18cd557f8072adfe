"""The schema of one parameter: what :data:`mgrao_core.params.PARAMETERS` lists, and what a family declares.

Apart from :mod:`mgrao_core.params` so that an algorithm family (:mod:`mgrao_core.algorithms`) can declare its
own parameters without importing the parameter set that lists them.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Parameter:
    """The schema of one parameter.

    Attributes:
        name: field name in :class:`SystemParams`.
        kind: ``"int"``, ``"float"``, ``"bool"`` or ``"choice"``.
        default: the documented default (``None`` only where ``nullable``).
        minimum: smallest allowed value (numbers only).
        maximum: largest allowed value (numbers only).
        exclusive_minimum: whether ``minimum`` itself is excluded.
        choices: allowed values of a ``"choice"`` parameter.
        nullable: whether ``None`` is allowed (it then means the documented automatic value).
        group: which part of the model it belongs to (for forms and docs).
        help: one sentence for people.
    """

    name: str
    kind: str
    default: Any
    help: str
    group: str
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False
    choices: tuple[str, ...] = ()
    nullable: bool = False

    def as_dict(self) -> dict[str, Any]:
        """The schema entry as plain JSON-ready data."""
        return dataclasses.asdict(self) | {"choices": list(self.choices)}
