"""An in-memory cache of serialized answers (results of succeeded jobs, study views by revision)."""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable


class AnswerCache:
    """Serialized answers that cannot change under their key, least recently used out.

    Each entry is built once, however many requests ask for it at the same time: the first builds,
    the others wait for it. An entry larger than the cap is served but not kept.
    """

    def __init__(self, max_bytes: int = 64 * 1024**2) -> None:
        self.max_bytes = max_bytes
        self._entries: OrderedDict[tuple, bytes] = OrderedDict()
        self._size = 0
        self._building: dict[tuple, threading.Event] = {}
        self._lock = threading.Lock()
        self.builds = 0

    def get_or_build(self, key: tuple, build: Callable[[], bytes]) -> bytes:
        """The cached bytes of ``key``, built by one caller when missing."""
        while True:
            with self._lock:
                if key in self._entries:
                    self._entries.move_to_end(key)
                    return self._entries[key]
                pending = self._building.get(key)
                if pending is None:
                    pending = self._building[key] = threading.Event()
                    break
            pending.wait()  # another request builds it; then look again (it may not have been kept)
            with self._lock:
                if key in self._entries:
                    self._entries.move_to_end(key)
                    return self._entries[key]
                if key not in self._building:
                    return self._build_uncached(key, build)
        try:
            value = build()
            with self._lock:
                self.builds += 1
                if len(value) <= self.max_bytes:
                    self._entries[key] = value
                    self._size += len(value)
                    while self._size > self.max_bytes:
                        _, evicted = self._entries.popitem(last=False)
                        self._size -= len(evicted)
            return value
        finally:
            with self._lock:
                self._building.pop(key).set()

    def _build_uncached(self, key: tuple, build: Callable[[], bytes]) -> bytes:
        with self._lock:
            self.builds += 1
        return build()

    @property
    def size(self) -> int:
        """Bytes held."""
        return self._size
