"""Parameters of the list and event-list kinds, added to the schema for a test only.

The real ones (``composite_periods``, ``schedule``) come with the engine's elements of issue 20; the
plumbing around the kinds (API, form, command line, studies, saved systems, identity) is tested with
these look-alikes, registered in-process by :func:`registered` (the app under ``TestClient`` and the
in-process worker see them; the engine ignores parameters it does not read).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import pytest

import mgrao_core
import mgrao_core.params as core_params
import mgrao_core.search as core_search
from mgrao_core.parameter import Parameter

EXAMPLE_PERIODS = Parameter(
    "example_periods", "list", (), "Periods of each composite type (a test parameter).", "example",
    1, 1000, item_kind="int", min_items=0, max_items=50,
)
EXAMPLE_SCHEDULE = Parameter(
    "example_schedule", "events", (), "Events at given episodes (a test parameter).", "example",
    min_items=0, max_items=20,
    fields=(
        Parameter("episode", "int", None, "Episode at which the event applies.", "example", 0, 100_000),
        Parameter("change", "choice", "new-profiles", "What changes.", "example",
                  choices=("new-profiles", "new-composites", "frequencies")),
        Parameter("fraction", "float", 0.3, "Fraction of parents concerned.", "example", 0.0, 1.0),
    ),
)
EXAMPLE_RATE = Parameter("example_rate", "float", 0.5, "A scalar added after issue 20 (a test parameter).",
                         "example", 0.0, 1.0)
EXAMPLES = (EXAMPLE_PERIODS, EXAMPLE_SCHEDULE, EXAMPLE_RATE)


@contextmanager
def registered(monkeypatch: pytest.MonkeyPatch, *extra: Parameter) -> Iterator[None]:
    """``extra`` (``EXAMPLES`` when none given) appended to :data:`mgrao_core.params.PARAMETERS` while inside."""
    parameters = (*core_params.PARAMETERS, *(extra or EXAMPLES))
    by_name = {p.name: p for p in parameters}
    made = core_params.system_params_class(parameters)
    import backend.api.routes.systems as systems_route

    for module in (core_params, mgrao_core, systems_route):
        monkeypatch.setattr(module, "PARAMETERS", parameters)
    for module in (core_params, core_search):
        monkeypatch.setattr(module, "PARAMETERS_BY_NAME", by_name)
    for module in (core_params, mgrao_core):
        monkeypatch.setattr(module, "SystemParams", made)
    yield

