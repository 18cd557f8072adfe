"""Results and comparisons: bounded answers, one build per cached entry, partial jobs, stored non-finite values."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from backend_helpers import JSON, drain
from fastapi.testclient import TestClient
from sqlalchemy import update

from backend.execution.worker import Worker
from backend.services import analysis
from backend.services.cache import AnswerCache
from backend.store import crud, queue
from backend.store.db import Database
from backend.store.models import Job, Run
from mgrao_core import make_spec, run_chunk
from tests.support.waiting import join_all


def submit(client: TestClient, **body: object) -> dict:
    response = client.post("/api/jobs", json={"system": "single", "seeds": 3, "episodes": 15, **body})
    assert response.status_code == 202, response.text
    return response.json()


def test_stored_non_finite_values_never_make_an_endpoint_fail(client: TestClient, worker: Worker, db: Database):
    # a value a bug or an old version might have stored: every endpoint answers, with null for it
    job = submit(client)
    other = submit(client)
    assert drain(worker) == 2
    with db.write() as session:
        bad = np.array([np.nan, np.inf, -np.inf] + [1.0] * 12, dtype="<f8").tobytes()
        session.execute(update(Run).where(Run.job_id == job["id"], Run.algorithm == "mgrao-max", Run.seed == 0)
                        .values(utilities=bad, combined_weights=np.full(20, np.nan, dtype="<f8").tobytes()))
    analysis.RESULTS_CACHE.__init__()
    results = client.get(f"/api/jobs/{job['id']}/results?include_seeds=true")
    assert results.status_code == 200, results.text
    config = next(c for c in results.json()["configurations"] if c["algorithm"] == "mgrao-max")
    assert config["episodes"]["mean"][0] is None and config["episodes"]["mean"][5] is not None
    seed0 = next(s for s in config["seeds"] if s["seed"] == 0)
    assert seed0["utility"][:3] == [None, None, None]
    as_json = client.get(f"/api/jobs/{job['id']}/episodes?format=json")
    assert as_json.status_code == 200
    values = [row["utility"] for row in as_json.json() if row["algorithm"] == "mgrao-max" and row["seed"] == 0]
    assert values[:3] == [None, None, None] and values[3] == 1.0
    assert client.get(f"/api/jobs/{job['id']}/episodes?format=csv").status_code == 200
    compare = client.get(f"/api/compare?jobs={job['id']},{other['id']}")
    assert compare.status_code == 200, compare.text


def test_points_beyond_the_response_limit_are_refused_naming_it(client: TestClient, worker: Worker) -> None:
    job = submit(client, seeds=2, episodes=2000, algorithms=["uniform", "mgrao-1:1"])
    assert drain(worker) == 1
    limit = analysis.MAX_RESPONSE_VALUES
    analysis.MAX_RESPONSE_VALUES = 3000
    try:
        # 2 configurations x 3 curves: 500 points each fit, 2000 do not
        default = client.get(f"/api/jobs/{job['id']}/results").json()
        assert default["points"] == 500 and len(default["configurations"][0]["episodes"]["mean"]) == 500
        refused = client.get(f"/api/jobs/{job['id']}/results?points=2000")
        assert refused.status_code == 422
        detail = refused.json()["detail"][0]
        assert detail["field"] == "points" and "3,000 values" in detail["msg"] and "points <= 500" in detail["msg"]
        seeds = client.get(f"/api/jobs/{job['id']}/results?include_seeds=true&points=2000")
        assert seeds.status_code == 422 and seeds.json()["detail"][0]["field"] == "include_seeds"
        fits = client.get(f"/api/jobs/{job['id']}/results?include_seeds=true&points=100")
        assert fits.status_code == 200 and len(fits.json()["configurations"][0]["seeds"][0]["utility"]) == 100
        compare = client.get(f"/api/compare?jobs={job['id']}&points=2000")
        assert compare.status_code == 422 and compare.json()["detail"][0]["field"] == "points"
    finally:
        analysis.MAX_RESPONSE_VALUES = limit


def test_concurrent_requests_build_a_cached_entry_once() -> None:
    cache = AnswerCache(max_bytes=1000)
    started = threading.Event()

    def slow_build() -> bytes:
        started.set()
        time.sleep(0.2)
        return b"x" * 100

    answers: list[bytes] = []
    threads = [threading.Thread(target=lambda: answers.append(cache.get_or_build(("k",), slow_build)), daemon=True)
               for _ in range(20)]
    for thread in threads:
        thread.start()
    join_all(threads, 60, "20 requests of one cache entry")
    assert answers == [b"x" * 100] * 20
    assert cache.builds == 1


def test_the_cache_never_keeps_an_entry_larger_than_its_cap_and_stays_within_it() -> None:
    cache = AnswerCache(max_bytes=1000)
    assert cache.get_or_build(("big",), lambda: b"y" * 1001) == b"y" * 1001
    assert cache.size == 0
    assert cache.get_or_build(("big",), lambda: b"y" * 1001) == b"y" * 1001
    assert cache.builds == 2  # served, never kept
    for i in range(5):
        cache.get_or_build((i,), lambda: b"z" * 400)
        assert cache.size <= 1000
    assert cache.builds == 7


def test_a_running_job_shows_the_chunks_stored_so_far(client: TestClient, db: Database) -> None:
    job = submit(client, seeds=[5, 6, 7, 8])
    claim = queue.claim(db, worker_id="w", stale_after_s=60, max_attempts=3)
    spec = make_spec("single", seeds=[5, 6, 7, 8], episodes=15)
    assert client.get(f"/api/jobs/{job['id']}/results").status_code == 409  # nothing stored yet
    assert queue.store_runs(db, claim=claim, rows=queue.run_rows(job["id"], run_chunk(spec, [5, 6])), progress=0.5)
    partial = client.get(f"/api/jobs/{job['id']}/results").json()
    assert partial["partial"] is True and partial["job"]["status"] == "running"
    assert [c["seeds_done"] for c in partial["configurations"]] == [2, 2, 2]
    assert [c["summary"]["n_runs"] for c in partial["configurations"]] == [2, 2, 2]
    episodes = client.get(f"/api/jobs/{job['id']}/episodes")
    assert episodes.headers["x-mgrao-partial"] == "true" and len(episodes.text.splitlines()) == 1 + 3 * 2 * 15
    assert client.post(f"/api/jobs/{job['id']}/cancel", headers=JSON).json()["status"] == "cancelled"
    kept = client.get(f"/api/jobs/{job['id']}/results").json()
    assert kept["partial"] is True and [c["seeds_done"] for c in kept["configurations"]] == [2, 2, 2]
    with db.session() as session:
        assert crud.get_job(session, job_id=job["id"]).status == "cancelled"


def test_a_succeeded_job_is_not_partial(client: TestClient, worker: Worker, db: Database) -> None:
    job = submit(client)
    assert drain(worker) == 1
    results = client.get(f"/api/jobs/{job['id']}/results").json()
    assert results["partial"] is False and [c["seeds_done"] for c in results["configurations"]] == [3, 3, 3]
    assert client.get(f"/api/jobs/{job['id']}/episodes").headers["x-mgrao-partial"] == "false"
    with db.session() as session:
        assert session.get(Job, job["id"]).status == "succeeded"


@pytest.mark.parametrize("points", [None, 7])
def test_streamed_bands_equal_the_core_bands(client: TestClient, worker: Worker, points: int | None) -> None:
    job = submit(client, seeds=[1, 2, 3, 4], episodes=30)
    assert drain(worker) == 1
    query = "" if points is None else f"?points={points}"
    results = client.get(f"/api/jobs/{job['id']}/results{query}").json()
    from mgrao_core import run_experiment

    expected = run_experiment(make_spec("single", seeds=[1, 2, 3, 4], episodes=30)).episode_bands(points)
    for config in results["configurations"]:
        band = expected[config["algorithm"]]
        np.testing.assert_allclose(config["episodes"]["mean"], band["mean"], rtol=1e-12)
        np.testing.assert_allclose(config["episodes"]["low"], band["low"], rtol=1e-12)
