"""A bounded pool of threads of its own for answers that cost seconds of CPU (the comparison statistics).

A route that runs in anyio's worker threads shares one limiter (40 tokens) with every synchronous route of
the service: forty requests for statistics that each wait their turn hold every token, and a health check,
a job page or a submission then waits behind them (issue 47, item 7: 61-66 s under a burst of 100). The
statistics' routes are therefore ``async``: they wait in the event loop, holding no thread, for a pool of
their own (:class:`ComputePool`), which bounds

* the answers computed at once (``workers`` threads, ``MGRAO_STATS_WORKERS``),
* the requests waiting for a thread (``queue``, ``MGRAO_STATS_QUEUE``): one more is refused at once with
  :class:`backend.errors.Busy` (503 with ``Retry-After: MGRAO_STATS_RETRY_AFTER_S``),
* how long a request waits for its thread (``wait_s``, ``MGRAO_STATS_WAIT_S``): then it is answered 503 too,

so that every request is answered within ``wait_s`` plus one computation, the process holds at most
``workers`` answers' arrays, and a waiting request costs a coroutine. Requests for the same answer (same
key) share one computation and one place in the queue. A computation whose every requester has gone
(the client closed its connection, or waited its longest) before it started is not run; one already
running finishes (the core's bootstrap cannot be stopped midway) and its answer is kept by the caller's
cache, for the retry.

The threads hold the GIL only between numpy's calls (the bootstrap's draws, indexing and percentiles
release it), so the event loop still answers the light routes meanwhile: benchmarks/bench_stats_burst.py
measures it (docs/service.md, "Statistics under load").
"""

from __future__ import annotations

import asyncio
import logging
import threading
import time
from collections.abc import Awaitable, Callable, Hashable
from concurrent.futures import Future, ThreadPoolExecutor

from backend.errors import Busy

log = logging.getLogger("mgrao.api")
POLL_S = 0.25
"""How often a waiting request looks whether its client is still there."""


class ClientGone(Exception):  # noqa: N818 - not an error of the service: nobody is left to answer
    """The request's client closed its connection before its answer was ready."""


class _Task:
    """One computation and the requests waiting for it."""

    def __init__(self, what: str) -> None:
        self.what = what
        self.waiters = 0
        self.started = False
        self.future: Future[bytes] | None = None


class ComputePool:
    """At most ``workers`` computations at once, ``queue`` more waiting, each waiting at most ``wait_s``.

    Args:
        workers: threads of the pool.
        queue: computations waiting for a thread at most (0: none waits; a request finding every thread
            busy is refused).
        retry_after_s: the ``Retry-After`` of a refusal, in seconds.
        wait_s: longest time a request waits for its computation to start.
        name: the threads' name, and what a refusal calls the answers (e.g. "statistics").
    """

    def __init__(self, *, workers: int, queue: int, retry_after_s: int, wait_s: float, name: str) -> None:
        self.workers, self.queue, self.name = workers, queue, name
        self.retry_after_s, self.wait_s = retry_after_s, wait_s
        self._executor = ThreadPoolExecutor(max_workers=workers, thread_name_prefix=f"mgrao-{name}")
        self._lock = threading.Lock()
        self._tasks: dict[Hashable, _Task] = {}
        """The computations running or waiting, by key."""

    def _busy(self, why: str) -> Busy:
        return Busy(f"the {self.name} are busy: {why}; retry after {self.retry_after_s} s", self.retry_after_s)

    def _compute(self, key: Hashable, task: _Task, build: Callable[[], bytes]) -> bytes:
        with self._lock:
            task.started = True
            running = sum(t.started for t in self._tasks.values())
            waiting = len(self._tasks) - running
        log.info("%s: computing (%d running, %d waiting)", task.what, running, waiting)
        try:
            return build()
        finally:
            with self._lock:
                if self._tasks.get(key) is task:
                    del self._tasks[key]

    def _join(self, key: Hashable, build: Callable[[], bytes], what: str) -> _Task:
        """The task computing ``key`` (a new one, queued, if none), with one more waiter; :class:`Busy` if full."""
        with self._lock:
            task = self._tasks.get(key)
            if task is None:
                if len(self._tasks) >= self.workers + self.queue:
                    raise self._busy(f"{self.workers} computing and {self.queue} waiting, the most this service takes "
                                     "(MGRAO_STATS_WORKERS, MGRAO_STATS_QUEUE)")
                task = self._tasks[key] = _Task(what)
                task.future = self._executor.submit(self._compute, key, task, build)
            task.waiters += 1
            return task

    def _leave(self, key: Hashable, task: _Task) -> None:
        """One waiter fewer; the last one gone before the computation started takes it out of the queue."""
        with self._lock:
            task.waiters -= 1
            if task.waiters or task.started or task.future is None or not task.future.cancel():
                return
            if self._tasks.get(key) is task:
                del self._tasks[key]
        log.info("%s: not computed, every request for it left before its turn", task.what)

    async def answer(self, key: Hashable, build: Callable[[], bytes], *, gone: Callable[[], Awaitable[bool]],
                     what: str = "") -> bytes:
        """``build()``'s bytes, computed in the pool (shared with the requests for ``key`` waiting already).

        Args:
            key: what the answer is (requests with equal keys share a computation).
            build: computes it, in a pool thread.
            gone: whether the request's client has gone (``Request.is_disconnected``).
            what: how a log line names the answer.

        Raises:
            Busy: the pool is full, or the computation did not start within ``wait_s``.
            ClientGone: the client went before the answer was ready.
        """
        task = self._join(key, build, what or str(key))
        assert task.future is not None
        waited = asyncio.wrap_future(task.future)
        arrived = time.monotonic()
        try:
            while True:
                done, _ = await asyncio.wait({waited}, timeout=POLL_S)
                if done:
                    return waited.result()
                if await gone():
                    raise ClientGone
                if not task.started and time.monotonic() - arrived > self.wait_s:
                    raise self._busy(f"this request waited {self.wait_s:g} s for its turn (MGRAO_STATS_WAIT_S)")
        finally:
            self._leave(key, task)

    def close(self) -> None:
        """Cancel what waits, and stop the threads once their computations end (without waiting for them)."""
        self._executor.shutdown(wait=False, cancel_futures=True)
