"""Large answers go back to the operating system when they are done (glibc only; a no-op elsewhere).

glibc serves an allocation above its *mmap threshold* with a mapping of its own, returned to the
system on free; but after such a block is freed it raises the threshold to that block's size, so
the next answers of a few dozen megabytes come from the heap, which keeps its memory. And what a
request thread reads (runs of a few hundred kilobytes each) lands in that thread's arena, whose
freed pages stay with the process. After a burst of large results the API would stay at its peak.
So the threshold is pinned (1 MiB), and :func:`trim` hands the arenas' free pages back after each
large build.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging

M_MMAP_THRESHOLD = -3  # glibc's mallopt parameter number
MMAP_THRESHOLD_BYTES = 1024**2

log = logging.getLogger("mgrao.api")


def _libc() -> ctypes.CDLL | None:
    name = ctypes.util.find_library("c")
    if not name:
        return None
    try:
        return ctypes.CDLL(name)
    except OSError:
        return None


def trim() -> None:
    """Give the free pages of every malloc arena back to the system (``malloc_trim(0)``)."""
    libc = _libc()
    if libc is not None and hasattr(libc, "malloc_trim"):
        libc.malloc_trim(0)


def return_large_blocks() -> bool:
    """Pin glibc's mmap threshold; False where there is no glibc (nothing changes then)."""
    libc = _libc()
    mallopt = getattr(libc, "mallopt", None)
    if mallopt is None:
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    done = mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES) == 1
    if not done:
        log.warning("could not pin malloc's mmap threshold; memory of large answers may stay with the process")
    return done
