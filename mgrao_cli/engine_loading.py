"""Load the compiled engine for a command that simulates, paying as little as possible for it.

Importing the engine (numba with it) creates tens of thousands of objects that live as long as the
process. While they are created, Python's cyclic garbage collector runs every few hundred
allocations and scans the young ones again and again, and at exit it scans them all once more; none
of them is ever garbage. :func:`load_engine` imports the engine with the collector paused and then
freezes (:func:`gc.freeze`) every object alive at that point, so that no later collection, the one
at exit included, scans them. This is the command line's business, not the library's: it changes
the process's collector, which a library must leave alone.
"""

from __future__ import annotations

import gc
import sys


def load_engine() -> None:
    """Import :mod:`mgrao_core.runner` (numba and the compiled engine) with the collector paused, then freeze.

    Nothing happens when the engine is imported already (as in a test process).
    """
    if "mgrao_core.runner" in sys.modules:
        return
    enabled = gc.isenabled()
    gc.disable()
    try:
        import mgrao_core.runner  # noqa: F401  (the import is the point)
    finally:
        gc.freeze()
        if enabled:
            gc.enable()
