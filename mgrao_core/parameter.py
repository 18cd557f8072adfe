"""The schema of one parameter: what :data:`mgrao_core.params.PARAMETERS` lists, and what a family declares.

Apart from :mod:`mgrao_core.params` so that an algorithm family (:mod:`mgrao_core.algorithms`) can declare its
own parameters without importing the parameter set that lists them.

Kinds (docs/model.md, "Parameter kinds"): ``"int"``, ``"float"``, ``"bool"`` and ``"choice"`` hold one value;
``"list"`` a list of numbers (``item_kind`` ``"int"`` or ``"float"``, each item within ``minimum`` and
``maximum``, between ``min_items`` and ``max_items`` items), held as a tuple; ``"events"`` a list of objects
whose fields are described by nested parameters (``fields``), held as a tuple of :class:`Record`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

_VALUE_KINDS = ("int", "float", "bool", "choice")
_EXTRA = ("item_kind", "min_items", "max_items", "fields", "identity")
IDENTITIES = ("always", "when-set")
"""The values of :attr:`Parameter.identity`."""
"""The fields only ``"list"`` and ``"events"`` parameters describe (absent from the others' :meth:`as_dict`)."""


@dataclass(frozen=True)
class Parameter:
    """The schema of one parameter.

    Attributes:
        name: field name in :class:`SystemParams`.
        kind: ``"int"``, ``"float"``, ``"bool"``, ``"choice"``, ``"list"`` or ``"events"``.
        default: the documented default (``None`` only where ``nullable``; a tuple for a list, a tuple of
            :class:`Record` for events).
        minimum: smallest allowed value (numbers, and each item of a list).
        maximum: largest allowed value (numbers, and each item of a list).
        exclusive_minimum: whether ``minimum`` itself is excluded.
        choices: allowed values of a ``"choice"`` parameter.
        nullable: whether ``None`` is allowed (it then means the documented automatic value).
        group: which part of the model it belongs to (for forms and docs).
        help: one sentence for people.
        item_kind: a list's item kind, ``"int"`` or ``"float"``.
        min_items: fewest items of a list or an event list.
        max_items: most items of a list or an event list.
        fields: an event list's fields, one nested parameter each (a default of ``None`` on a field that is
            not nullable makes it required).
        identity: how the parameter enters a configuration's identity (its stored ``params`` and its
            ``config_hash``): ``"always"`` (the parameters the service had before issue 20: every stored
            configuration names them) or ``"when-set"`` (every parameter added since: named only when it differs
            from ``default``, so that adding it leaves the hash of every existing configuration unchanged).
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
    item_kind: str | None = None
    min_items: int | None = None
    max_items: int | None = None
    fields: tuple[Parameter, ...] = ()
    identity: str = "when-set"

    def __post_init__(self) -> None:
        if self.identity not in IDENTITIES:
            raise ValueError(f"parameter {self.name}: identity must be one of {', '.join(IDENTITIES)}")
        if self.kind == "list" and self.item_kind not in ("int", "float"):
            raise ValueError(f"{self.name}: a list's item_kind is 'int' or 'float' (got {self.item_kind!r})")
        if self.kind == "events" and (not self.fields or any(f.kind not in _VALUE_KINDS for f in self.fields)):
            raise ValueError(f"{self.name}: an event list's fields are int, float, bool or choice parameters")

    @property
    def item(self) -> Parameter:
        """A list's item as a parameter of its own (named after the list)."""
        return Parameter(self.name, self.item_kind or "float", None, self.help, self.group, self.minimum,
                         self.maximum, self.exclusive_minimum)

    def as_dict(self) -> dict[str, Any]:
        """The schema entry as plain JSON-ready data.

        Every kind gives ``name, kind, default, help, group, minimum, maximum, exclusive_minimum, choices,
        nullable``; a ``"list"`` adds ``item_kind, min_items, max_items`` (``minimum``/``maximum`` then bound each
        item) and its default is a list; ``"events"`` adds ``min_items, max_items`` and ``fields`` (each field's own
        entry) and its default is a list of objects.
        """
        entry = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name not in _EXTRA}
        entry = dataclasses.asdict(self) if self.kind in _VALUE_KINDS else entry  # as before the new kinds
        entry = {k: v for k, v in entry.items() if k not in _EXTRA} | {"choices": list(self.choices)}
        if self.kind == "list":
            entry |= {"default": list(self.default), "item_kind": self.item_kind, "min_items": self.min_items,
                      "max_items": self.max_items}
        elif self.kind == "events":
            entry |= {"default": [r.as_dict() for r in self.default], "min_items": self.min_items,
                      "max_items": self.max_items, "fields": [f.as_dict() for f in self.fields]}
        return entry


@dataclass(frozen=True)
class Record:
    """One object of an event list: its fields in the schema's order, immutable, read as attributes.

    ``Record.of({"episode": 50, "change": "new-profiles"}).episode`` is 50; :meth:`as_dict` gives the plain object.
    """

    items: tuple[tuple[str, Any], ...]

    @classmethod
    def of(cls, values: Mapping[str, Any]) -> Record:
        """A record of ``values`` (already validated), in their order."""
        return cls(tuple(values.items()))

    def __getattr__(self, name: str) -> Any:
        for key, value in object.__getattribute__(self, "items"):
            if key == name:
                return value
        raise AttributeError(name)

    def as_dict(self) -> dict[str, Any]:
        """The record as a plain JSON-ready object."""
        return dict(self.items)
