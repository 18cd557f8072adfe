"""Numba's on-disk cache of the kernel, made to notice changes in any of the engine's files.

Numba keys a cached function on its own source file alone. The kernel inlines functions from
:mod:`~mgrao_core.engine.environment` and :mod:`~mgrao_core.engine.learning`, so after an edit of
either (or a checkout that touches only them) numba would load the old kernel and compute old
numbers. :func:`bind_to_sources` adds a digest of every engine source to the stamp numba checks,
so any change recompiles the kernel.
"""

from __future__ import annotations

import hashlib
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

ENGINE_DIR = Path(__file__).resolve().parent


def sources_digest(directory: Path = ENGINE_DIR) -> str:
    """sha256 of every ``.py`` file of the engine package, by name and content."""
    digest = hashlib.sha256()
    for path in sorted(directory.glob("*.py")):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()


def bind_to_sources(dispatchers: Iterable[Any], digest: str | None = None) -> None:
    """Make the cache of each numba dispatcher valid only for the current engine sources.

    Call it before the dispatchers first run. Should numba's internals not look as expected, the
    cached kernel is not trusted: its index is flushed (one compile per process) with a warning.
    """
    digest = digest or sources_digest()
    for dispatcher in dispatchers:
        cache = getattr(dispatcher, "_cache", None)
        cache_file = getattr(cache, "_cache_file", None)
        stamp = getattr(cache_file, "_source_stamp", None)
        if stamp is None:
            if cache is not None and hasattr(cache, "flush"):
                warnings.warn("numba's cache layout is unknown: the kernel is recompiled in every process",
                              RuntimeWarning, stacklevel=2)
                cache.flush()
            continue
        if not (isinstance(stamp, tuple) and len(stamp) == 2 and stamp[1] == digest):
            cache_file._source_stamp = (stamp, digest)
