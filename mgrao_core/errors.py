"""The core library's exceptions; the web and command-line edges translate them."""

from __future__ import annotations


class MgraoError(Exception):
    """Base class of every error the core raises on purpose."""


class ConfigError(MgraoError, ValueError):
    """A configuration value is missing, of the wrong type or outside its limits.

    Attributes:
        field: the name of the offending field (e.g. ``"n_parents"`` or ``"algorithms[2]"``).
        message: what is wrong, naming the limit.
    """

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


class ConfigErrors(ConfigError):
    """Several fields refused at once: every one of them in :attr:`errors`, in the order of the fields.

    Its own ``field`` and ``message`` are the first error's, so that a caller that reads one error reads that.
    """

    def __init__(self, errors: list[ConfigError]) -> None:
        super().__init__(errors[0].field, errors[0].message)
        self.errors = tuple(e for error in errors for e in getattr(error, "errors", (error,)))


def raise_all(errors: list[ConfigError]) -> None:
    """Raise nothing for no error, the error itself for one, :class:`ConfigErrors` for several."""
    if len(errors) == 1:
        raise errors[0]
    if errors:
        raise ConfigErrors(errors)


class WorkLimitError(ConfigError):
    """The request would exceed a documented work or memory limit."""


class Cancelled(MgraoError):
    """The caller asked the run to stop (cooperative cancellation)."""


class NumericalError(MgraoError):
    """A simulation produced a utility or weight that is not finite (nothing of it may be stored)."""
