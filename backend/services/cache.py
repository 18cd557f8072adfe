"""Serialized answers, kept (results of succeeded jobs, study views by revision) or shared (job lists)."""

from __future__ import annotations

import asyncio
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable

from starlette.concurrency import run_in_threadpool


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

    def get(self, key: tuple) -> bytes | None:
        """The cached bytes of ``key``, or None (nothing is built, nothing waited for)."""
        with self._lock:
            if key in self._entries:
                self._entries.move_to_end(key)
                return self._entries[key]
            return None

    def _build_uncached(self, key: tuple, build: Callable[[], bytes]) -> bytes:
        with self._lock:
            self.builds += 1
        return build()

    @property
    def size(self) -> int:
        """Bytes held."""
        return self._size


class SharedBuilds:
    """Concurrent requests for one answer share a build that began after each of them arrived.

    Nothing is kept beyond a build: an answer is handed only to the requests that were waiting when
    its build started, and a request that arrives while a build runs waits for the next one. So
    every answer is read from the database after its request arrived, exactly as if the request
    had been alone (a change committed by any process before the request is in it), while N
    clients asking for the same page at once cost one or two builds instead of N. At most one
    build per key runs at a time; memory is bounded by the requests waiting. Call from the event
    loop; ``build`` runs in the thread pool, and its exception is raised to each request it serves.
    """

    def __init__(self) -> None:
        self._running: dict[Hashable, asyncio.Future[bytes]] = {}
        self._next: dict[Hashable, asyncio.Future[bytes]] = {}
        self.builds = 0

    async def get(self, key: Hashable, build: Callable[[], bytes]) -> bytes:
        """The answer of a build of ``key`` that starts after this call."""
        key = (asyncio.get_running_loop(), key)
        answer = self._next.get(key)
        if answer is None:
            answer = self._next[key] = asyncio.get_running_loop().create_future()
            asyncio.ensure_future(self._build(key, answer, build))  # not the request's task: a client gone
        return await asyncio.shield(answer)  # before it is answered leaves the others served

    async def _build(self, key: Hashable, answer: asyncio.Future[bytes], build: Callable[[], bytes]) -> None:
        running = self._running.get(key)
        if running is not None:
            await asyncio.wait([running])
        del self._next[key]  # from here on, new requests wait for the build after this one
        self._running[key] = answer
        try:
            self.builds += 1
            answer.set_result(await run_in_threadpool(build))
        except BaseException as error:  # noqa: BLE001 - handed to every request it serves
            answer.set_exception(error)
            answer.exception()  # retrieved here, so that no waiter left means no "never retrieved" warning
        finally:
            del self._running[key]
