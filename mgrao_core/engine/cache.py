"""Numba's on-disk cache of the kernel: stale after any change of what it compiles, loaded without the compiler.

Numba keys a cached function on its own source file alone. The kernel inlines functions from
:mod:`~mgrao_core.engine.environment`, :mod:`mgrao_core.quality` and the algorithm families'
compiled steps (``mgrao_core/algorithms/``), so after an edit of any of them (or a checkout that touches only them)
numba would load the old kernel and compute old numbers. :func:`bind_to_sources` adds a digest of
every compiled source (:data:`COMPILED_SOURCES`) to the stamp numba checks, so any change
recompiles the kernel.

Before it loads a cached function, numba imports and registers every implementation it has (its
target context's "refresh", about 0.15 s of a process that runs for under a second), which
compiling needs and running machine code does not. :func:`load_without_compiler` makes a load
initialise only numba's runtime (the allocator the compiled code calls); a miss compiles as before,
and compiling refreshes the context itself.

:func:`has_code` tells, before a call, whether it would compile: the runner says so while it does
(:class:`mgrao_core.compiling.Compiling`), and runs a chunk on the kernel of every family where that one is
at hand and the chunk's own is not.
"""

from __future__ import annotations

import hashlib
import warnings
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

PACKAGE_DIR = Path(__file__).resolve().parents[1]

COMPILED_SOURCES = ("engine/*.py", "quality.py", "equations.py", "world.py", "algorithms.py", "algorithms/**/*.py")
"""Every place, as a glob under ``mgrao_core/``, whose code the kernel compiles or reads at compile time.

The engine package; the quality models' compiled forms; the equations it compiles (a task share); the
algorithms, a module or a package of modules (a place that does not exist matches nothing). A module that gives
the kernel compiled code or constants belongs here: numba would not notice its edits.
"""


def compiled_sources(package: Path = PACKAGE_DIR) -> list[Path]:
    """The files of :data:`COMPILED_SOURCES` under ``package`` (``mgrao_core/``), sorted."""
    return sorted({path for pattern in COMPILED_SOURCES for path in package.glob(pattern) if path.is_file()})


def sources_digest(package: Path = PACKAGE_DIR) -> str:
    """sha256 of every compiled source (:func:`compiled_sources`), by its path under ``package`` and content."""
    digest = hashlib.sha256()
    for path in compiled_sources(package):
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def bind_to_sources(dispatchers: Iterable[Any], digest: str | None = None) -> None:
    """Make the cache of each numba dispatcher valid only for the current compiled sources.

    Call it before the dispatchers first run. Should numba's internals not look as expected, the
    cached kernel is not trusted: its index is flushed (one compile per process) with a warning.
    """
    digest = digest or sources_digest()
    for dispatcher in dispatchers:
        cache = getattr(dispatcher, "_cache", None)
        cache_file = getattr(cache, "_cache_file", None)
        stamp = getattr(cache_file, "_source_stamp", None)
        if stamp is None:
            if getattr(cache, "cache_path", None) is None:  # not cached at all (see mgrao_core._numba_cache)
                continue
            if hasattr(cache, "flush"):
                warnings.warn("numba's cache layout is unknown: the kernel is recompiled in every process",
                              RuntimeWarning, stacklevel=2)
                cache.flush()
            continue
        if not (isinstance(stamp, tuple) and len(stamp) == 2 and stamp[1] == digest):
            cache_file._source_stamp = (stamp, digest)


def argument_types(dispatcher: Any, arguments: Sequence[Any]) -> tuple:
    """The numba types of ``arguments`` as ``dispatcher`` types a call: the signature it compiles or looks up."""
    return tuple(dispatcher.typeof_pyval(a) for a in arguments)


def has_code(dispatcher: Any, types: tuple) -> bool:
    """Whether a call of ``dispatcher`` on arguments of ``types`` runs without compiling.

    True when this process compiled or loaded that signature already, or when numba's on-disk cache holds it
    for the current compiled sources (:func:`bind_to_sources`): a load of well under a second. False where it
    would compile, and wherever numba's cache does not look as expected (no cache, other internals): what
    is not known to be there is taken to be compiled.
    """
    if types in dispatcher.overloads:
        return True
    cache = getattr(dispatcher, "_cache", None)
    index_key = getattr(cache, "_index_key", None)
    cache_file = getattr(cache, "_cache_file", None)
    if index_key is None or not hasattr(cache_file, "_load_index") or not getattr(cache, "_enabled", True):
        return False
    try:
        return index_key(types, dispatcher.targetctx.codegen()) in cache_file._load_index()
    except Exception:  # noqa: BLE001  (an unreadable index is a cache that will compile)
        return False


def load_without_compiler(dispatchers: Iterable[Any]) -> None:
    """Make each numba dispatcher load its cached machine code without refreshing numba's compiler.

    Call it before the dispatchers first run. A dispatcher whose cache does not look as expected
    (no cache, or other numba internals) keeps numba's own loading; so does any load that fails.
    """
    try:
        from numba.core.runtime import rtsys
    except ImportError:  # numba's layout changed: keep its own loading
        return
    for dispatcher in dispatchers:
        cache = getattr(dispatcher, "_cache", None)
        load = getattr(cache, "_load_overload", None)
        guard = getattr(cache, "_guard_against_spurious_io_errors", None)
        if load is None or guard is None or not hasattr(cache, "load_overload") or not hasattr(rtsys, "initialize"):
            continue
        cache.load_overload = _lean_loader(cache.load_overload, load, guard, rtsys)


def _lean_loader(numbas_own: Any, load: Any, guard: Any, rtsys: Any) -> Any:
    def load_overload(sig: Any, target_context: Any) -> Any:
        try:
            rtsys.initialize(target_context)  # the runtime the code allocates through (refresh would do this too)
            with guard():
                return load(sig, target_context)  # None on a miss: the dispatcher compiles (and refreshes)
        except Exception:  # noqa: BLE001  (whatever went wrong, numba's own path decides)
            return numbas_own(sig, target_context)

    return load_overload
