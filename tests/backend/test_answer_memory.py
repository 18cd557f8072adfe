"""The API's memory under concurrent requests for large results stays bounded, and goes back after.

A real ``mgrao serve`` answers 20 concurrent requests for the results of a job with 1,000 runs of
10,000 episodes, with every seed's curve: each answer is about 20 MB. The API builds at most two at
a time, sends cached answers without copying them, and returns the memory afterwards
(backend/services/memory.py). The peak and the resident memory after are read from /proc.
"""

from __future__ import annotations

import threading
from pathlib import Path

import httpx
import pytest
from backend_helpers import Service

from tests.support.waiting import join_all

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads memory from /proc")]

JOB = {"system": "single", "algorithms": ["uniform", "mgrao-1:1"], "seeds": 500, "episodes": 10_000,
       "params": {"n_parents": 1, "types_per_composite": 1}}


def _status(pid: int, field: str) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) // 1024
    raise AssertionError(field)


def _burst(service: Service, job_id: int, queries: list[str]) -> list[int]:
    codes: list[int] = []

    def one(query: str) -> None:
        with httpx.Client(timeout=300) as client:
            response = client.get(f"{service.base}/api/jobs/{job_id}/results?{query}")
            codes.append(response.status_code)
            assert len(response.content) > 5_000_000

    threads = [threading.Thread(target=one, args=(q,), daemon=True) for q in queries]
    for thread in threads:
        thread.start()
    join_all(threads, 600, f"{len(queries)} concurrent results requests")
    return codes


@pytest.mark.parametrize("kind", ["identical", "distinct"])
def test_twenty_concurrent_large_answers(tmp_path: Path, kind: str) -> None:
    service = Service(tmp_path)
    try:
        service.start_server(workers=1)
        job_id = service.post("/api/jobs", json=JOB).json()["id"]
        service.wait_for(lambda: service.get(f"/api/jobs/{job_id}").json()["status"] == "succeeded",
                         timeout=300, what="the job")
        pid = service.server.pid
        Path(f"/proc/{pid}/clear_refs").write_text("5")  # VmHWM from here
        before = _status(pid, "VmRSS")
        queries = [f"include_seeds=true&points={900 - (i if kind == 'distinct' else 0)}" for i in range(20)]
        assert _burst(service, job_id, queries) == [200] * 20
        peak, after = _status(pid, "VmHWM") - before, _status(pid, "VmRSS") - before
    finally:
        service.stop()
    print(f"{kind}: peak +{peak} MiB, after +{after} MiB over {before} MiB")
    assert peak < 400, f"the API grew by {peak} MiB for 20 answers of about 20 MB"
    assert after < 150, f"the API kept {after} MiB after the burst"
