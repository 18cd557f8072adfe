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
        kind: ``"int"``, ``"float"``, ``"bool"``, ``"choice"``, ``"list"`` (a list of numbers) or ``"events"``
            (a list of objects whose fields are ``fields``).
        default: the documented default (``None`` only where ``nullable``).
        minimum: smallest allowed value (numbers only).
        maximum: largest allowed value (numbers only).
        exclusive_minimum: whether ``minimum`` itself is excluded.
        choices: allowed values of a ``"choice"`` parameter.
        nullable: whether ``None`` is allowed (it then means the documented automatic value).
        group: which part of the model it belongs to (for forms and docs).
        help: one sentence for people.
        identity: how the parameter enters a configuration's identity (its stored ``params`` and its
            ``config_hash``): ``"always"`` (the parameters the service had before issue 20: every stored
            configuration names them) or ``"when-set"`` (every parameter added since: named only when it differs
            from ``default``, so that adding it leaves the hash of every existing configuration unchanged).
        item_kind: a ``"list"``'s items, ``"int"`` or ``"float"`` (``minimum``/``maximum`` bound each item).
        min_items: fewest items of a ``"list"`` or ``"events"``.
        max_items: most items of a ``"list"`` or ``"events"``.
        fields: an ``"events"`` item's fields, each described by a parameter of a scalar kind.
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
    identity: str = "when-set"
    item_kind: str | None = None
    min_items: int = 0
    max_items: int | None = None
    fields: tuple[Parameter, ...] = ()

    def __post_init__(self) -> None:
        if self.identity not in IDENTITIES:
            raise ValueError(f"parameter {self.name}: identity must be one of {', '.join(IDENTITIES)}")

    def as_dict(self) -> dict[str, Any]:
        """The schema entry as plain JSON-ready data (an ``"events"``'s ``fields`` as a list of such entries)."""
        entry = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        default = self.default
        if isinstance(default, tuple):  # a list's or event list's default, frozen
            default = [dict(item) if isinstance(item, tuple) else item for item in default]
        return entry | {"default": default, "choices": list(self.choices), "fields": [f.as_dict() for f in self.fields]}


IDENTITIES = ("always", "when-set")
"""The values of :attr:`Parameter.identity`."""
