"""A compiled function's stand-in: calls go to a function of the test's, every other question to the dispatcher.

The runner asks numba's dispatcher of the kernel (``engine.run_block``) and of ``engine.finish`` for their argument
types and whether its cache holds their code (:func:`mgrao_core.runner.ready_kernel`) before it calls them, so a test
that replaces one to watch or intercept its calls must answer those questions as the dispatcher does.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


class StandIn:
    """``call(*arguments)`` when called; the ``dispatcher``'s attributes (``typeof_pyval``, its cache...) otherwise."""

    def __init__(self, dispatcher: Any, call: Callable[..., Any]) -> None:
        self._dispatcher = dispatcher
        self._call = call

    def __call__(self, *arguments: Any) -> Any:
        return self._call(*arguments)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._dispatcher, name)
