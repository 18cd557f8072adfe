"""backend.services.cache.SharedBuilds on its own: who shares which build, errors, and what is left behind."""

from __future__ import annotations

import asyncio
import threading

import pytest

from backend.services.cache import SharedBuilds

DEADLINE_S = 30


class Builds:
    """Builds numbered from 1 that each wait, in the thread pool, until the test lets them finish."""

    def __init__(self) -> None:
        self.started = 0
        self.release: list[threading.Event] = []
        self.began = threading.Semaphore(0)
        self.fail = False

    def __call__(self) -> bytes:
        self.started += 1
        number, gate = self.started, threading.Event()
        self.release.append(gate)
        self.began.release()
        assert gate.wait(DEADLINE_S), f"build {number} was not released within {DEADLINE_S} s"
        if self.fail:
            raise LookupError(f"build {number} failed")
        return f"build {number}".encode()

    async def wait_started(self, count: int) -> None:
        """Wait until ``count`` builds have begun (each, with a deadline)."""
        while self.started < count:
            began = await asyncio.to_thread(self.began.acquire, timeout=DEADLINE_S)
            assert began, f"build {self.started + 1} did not begin within {DEADLINE_S} s"


def test_a_request_during_a_build_gets_the_next_build_shared_with_the_others_waiting():
    async def scenario() -> None:
        shared, build = SharedBuilds(), Builds()
        first = asyncio.ensure_future(shared.get("page", build))
        await build.wait_started(1)
        # three requests arrive while build 1 runs: none of them may get it
        later = [asyncio.ensure_future(shared.get("page", build)) for _ in range(3)]
        other = asyncio.ensure_future(shared.get("another page", build))  # another key: its own build
        await build.wait_started(2)
        await asyncio.sleep(0.05)
        assert build.started == 2, "a second build of 'page' began while its first ran"
        build.release[0].set()
        assert await asyncio.wait_for(first, DEADLINE_S) == b"build 1"
        await build.wait_started(3)
        for gate in build.release:
            gate.set()
        answers = {await asyncio.wait_for(request, DEADLINE_S) for request in later}
        assert len(answers) == 1 and answers != {await asyncio.wait_for(first, DEADLINE_S)}, answers
        assert await asyncio.wait_for(other, DEADLINE_S) != answers.pop()
        assert shared.builds == 3
        assert not shared._running and not shared._next  # nothing kept once delivered

    asyncio.run(scenario())


def test_a_failed_build_raises_to_every_request_it_served_and_the_next_request_builds_again():
    async def scenario() -> None:
        shared, build = SharedBuilds(), Builds()
        build.fail = True
        first = asyncio.ensure_future(shared.get("page", build))
        await build.wait_started(1)
        waiting = [asyncio.ensure_future(shared.get("page", build)) for _ in range(2)]
        build.release[0].set()
        with pytest.raises(LookupError, match="build 1 failed"):
            await asyncio.wait_for(first, DEADLINE_S)
        await build.wait_started(2)
        build.release[1].set()
        for request in waiting:
            with pytest.raises(LookupError, match="build 2 failed"):
                await asyncio.wait_for(request, DEADLINE_S)
        build.fail = False
        again = asyncio.ensure_future(shared.get("page", build))
        await build.wait_started(3)
        build.release[2].set()
        assert await asyncio.wait_for(again, DEADLINE_S) == b"build 3"
        assert not shared._running and not shared._next

    asyncio.run(scenario())


def test_a_request_that_goes_away_leaves_the_others_served():
    async def scenario() -> None:
        shared, build = SharedBuilds(), Builds()
        leaving = asyncio.ensure_future(shared.get("page", build))
        staying = asyncio.ensure_future(shared.get("page", build))
        await build.wait_started(1)
        leaving.cancel()
        build.release[0].set()
        assert await asyncio.wait_for(staying, DEADLINE_S) == b"build 1"
        assert leaving.cancelled()
        assert not shared._running and not shared._next

    asyncio.run(scenario())
