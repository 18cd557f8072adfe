"""What every algorithm family declares: its label grammar, its description and its place in views.

A *family* is one kind of learner or baseline (``uniform``, ``oracle``, ``mgrao``); a *label* names
one configuration of a family (``mgrao-5:1``); an :class:`Algorithm` is a label parsed for a system.
Each family lives in its own module of :mod:`mgrao_core.algorithms` and is registered in
:data:`mgrao_core.algorithms.FAMILIES`; nothing outside the family's module parses its labels.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from mgrao_core.errors import ConfigError

PALETTE_SLOTS = 8
"""Colour keys are slots ``0 .. PALETTE_SLOTS - 1`` of the dashboard's colour-blind-safe palette."""


@dataclass(frozen=True)
class Algorithm:
    """A parsed algorithm label.

    Attributes:
        label: the canonical spelling, e.g. ``"mgrao-5:1"``.
        kind: the family's name: ``"uniform"``, ``"oracle"`` or ``"mgrao"``.
        n_groups: parent groups per child (MG-RAO only; 0 otherwise).
    """

    label: str
    kind: str
    n_groups: int = 0


@dataclass(frozen=True)
class LabelForm:
    """One way of writing a family's labels, for forms that build labels from it.

    A literal form (``argument`` None) is the label ``template`` itself; a form with an argument
    is ``template`` with ``{x}`` replaced by a whole number (``pattern`` matches the canonical and
    the accepted spellings, with the number as its first group).
    """

    template: str
    pattern: str
    description: str
    argument: str | None = None
    argument_help: str = ""

    def as_dict(self, n_parents: int | None = None, valid: list[int] | None = None) -> dict[str, Any]:
        """JSON-ready; ``valid`` lists the argument's allowed values for a system when known."""
        out: dict[str, Any] = {"template": self.template, "pattern": self.pattern, "description": self.description,
                               "argument": self.argument, "argument_help": self.argument_help}
        if self.argument is not None:
            out["valid"] = valid
        return out


class Family:
    """The label side of an algorithm family; each family's module defines one subclass and an instance.

    Subclasses set the class attributes and implement :meth:`parse`, :meth:`forms`,
    :meth:`examples`, :meth:`colour_key` and :meth:`order`.
    """

    name: str = ""
    """The family's name, also :attr:`Algorithm.kind` of its labels."""
    title: str = ""
    """A short human name (``"MG-RAO"``)."""
    description: str = ""
    """One or two sentences for people: what the family does."""
    rank: int = 0
    """Where the family's configurations come in views (lower first)."""

    def parse(self, text: str, n_parents: int | None, field: str) -> Algorithm | None:
        """The algorithm that lower-cased, stripped ``text`` names, or None if it is not this family's.

        ``n_parents`` None checks the grammar alone (no system yet). Raises :class:`ConfigError`
        (naming ``field``) for a label of this family that is invalid for the system.
        """
        raise NotImplementedError

    def forms(self, n_parents: int | None) -> list[dict[str, Any]]:
        """The family's :class:`LabelForm` s as JSON, with the arguments valid for ``n_parents``."""
        raise NotImplementedError

    def examples(self, n_parents: int | None) -> list[str]:
        """Labels of this family valid for a system of ``n_parents`` parents (a few, for forms)."""
        raise NotImplementedError

    def hint(self, n_parents: int | None) -> str:
        """How to write the family's labels, for the error of an unknown label."""
        raise NotImplementedError

    def colour_key(self, algorithm: Algorithm) -> int:
        """The palette slot the configuration prefers (``0 .. PALETTE_SLOTS - 1``), the same in every view."""
        raise NotImplementedError

    def order(self, algorithm: Algorithm) -> int:
        """The configuration's place within its family in views (lower first)."""
        return 0

    def sort_key(self, algorithm: Algorithm) -> tuple[int, int]:
        """Views order configurations by family rank, then by :meth:`order`."""
        return (self.rank, self.order(algorithm))


def invalid(field: str, message: str) -> ConfigError:
    """The error of a label that its family recognises but the system does not allow."""
    return ConfigError(field, message)
