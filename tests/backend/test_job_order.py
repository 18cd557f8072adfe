"""The runs table's columns: jobs listed with their stored summaries, sorted by a configuration's
result or by any parameter, page by page, on SQLite and on PostgreSQL."""

from __future__ import annotations

import base64
import json

import pytest
from sqlalchemy import delete, func, select

from backend.store import crud, summaries
from backend.store.db import Database
from backend.store.models import JobSummary
from mgrao_core import make_spec, run_experiment
from tests.backend.backend_helpers import drain, listing_statements

LEARNING_RATES = [0.3, 0.05, 0.5, 0.1, 0.2]


@pytest.fixture
def finished_jobs(client, worker) -> list[dict]:
    """Five succeeded jobs differing in learning rate, and one queued job (no summaries)."""
    jobs = []
    for rate in LEARNING_RATES:
        body = {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 3, "episodes": 15,
                "params": {"learning_rate": rate}, "name": f"lr {rate}"}
        jobs.append(client.post("/api/jobs", json=body).json())
    assert drain(worker) == len(LEARNING_RATES)
    waiting = {"system": "single", "seeds": 1, "episodes": 5, "name": "waiting"}
    jobs.append(client.post("/api/jobs", json=waiting).json())
    return jobs


def all_pages(client, sort: str, limit: int = 2, most: int = 100) -> list[dict]:
    rows, cursor = [], None
    for _ in range(most):  # a cursor that never ends fails here instead of looping forever
        params = {"sort": sort, "limit": limit} | ({"cursor": cursor} if cursor else {})
        answer = client.get("/api/jobs", params=params)
        assert answer.status_code == 200, answer.text
        page = answer.json()
        rows += page["data"]
        cursor = page["next_cursor"]
        if cursor is None:
            return rows
    raise AssertionError(f"still a next_cursor after {most} pages of {limit} (sort {sort}): {len(rows)} rows")


def test_listed_jobs_carry_the_summaries_stored_when_they_succeeded(client, finished_jobs):
    listed = {job["id"]: job for job in client.get("/api/jobs").json()["data"]}
    first = listed[finished_jobs[0]["id"]]
    assert set(first["summaries"]) == {"uniform", "mgrao-max"}
    stored = first["summaries"]["mgrao-max"]
    # the same figures as the job's results (computed from the runs there)
    results = client.get(f"/api/jobs/{first['id']}/results").json()
    expected = next(c["summary"] for c in results["configurations"] if c["algorithm"] == "mgrao-max")
    for key in ("n_runs", "final_mean", "pct_from_uniform", "pct_of_max"):
        assert stored[key] == pytest.approx(expected[key], rel=1e-12, abs=1e-12), key
    assert stored["ci95"] == pytest.approx(expected["ci95"], rel=1e-12)
    assert listed[finished_jobs[-1]["id"]]["summaries"] == {}  # queued: nothing yet


@pytest.mark.parametrize("descending", [False, True])
def test_sorted_by_a_configurations_result_across_pages(client, finished_jobs, descending):
    sort = f"{'-' if descending else ''}pct_from_uniform:MGRAO-MAX"  # any spelling of the configuration
    rows = all_pages(client, sort)
    assert len(rows) == len(finished_jobs) and len({r["id"] for r in rows}) == len(rows)
    values = [r["summaries"]["mgrao-max"]["pct_from_uniform"] for r in rows[:-1]]
    assert values == sorted(values, reverse=descending)
    assert rows[-1]["name"] == "waiting"  # without the value: last, in either direction


@pytest.mark.parametrize("descending", [False, True])
def test_sorted_by_any_parameter_across_pages(client, finished_jobs, descending):
    rows = all_pages(client, f"{'-' if descending else ''}param.learning_rate")
    rates = [r["params"]["learning_rate"] for r in rows]
    assert rates == sorted([*LEARNING_RATES, 0.1], reverse=descending)  # the queued job has the default 0.1
    assert len({r["id"] for r in rows}) == len(finished_jobs)
    names = [r["params"]["quality_model"] for r in all_pages(client, "param.quality_model")]
    assert len(names) == len(finished_jobs)


@pytest.mark.parametrize(("sort", "says"), [
    ("param.nope", "'nope' is not a parameter"),
    ("final_mean", "needs a configuration"),
    ("final_mean:mgrao-3:0", "y must be a whole number of at least 1"),  # mgrao-3:2 is a configuration now
    ("pct_of_max:bogus", "unknown algorithm"),
    ("size", "is not an order"),
])
def test_a_bad_sort_names_the_field(client, sort, says):
    answer = client.get("/api/jobs", params={"sort": sort})
    assert answer.status_code == 422
    detail = answer.json()["detail"][0]
    assert detail["loc"] == ["query", "sort"] and says in detail["msg"]


def test_crafted_cursors_answer_422_or_a_page_never_500(client, finished_jobs):
    def cursor(*parts) -> str:
        return base64.urlsafe_b64encode(json.dumps(list(parts)).encode()).decode().rstrip("=")

    sort = "-final_mean:mgrao-max"
    cases = [
        (sort, cursor(sort, 2**70, 5), 200),  # a key past 2^63 is compared as a float, not bound as an integer
        (sort, cursor(sort, 1.0, 2**63), 422),
        (sort, cursor(sort, "x", 5), 422),
        (sort, cursor("name", 1.0, 5), 422),
        (sort, cursor(sort, float("inf"), 3), 422),
        ("param.load_sharing", cursor("param.load_sharing", 7, 3), 422),
        ("param.load_sharing", cursor("param.load_sharing", False, 3), 200),
    ]
    for order, bad, expected in cases:
        answer = client.get("/api/jobs", params={"sort": order, "cursor": bad})
        assert answer.status_code == expected, (order, bad, answer.text)
        if expected == 422:
            assert answer.json()["detail"][0]["loc"] == ["query", "cursor"]


def test_summaries_are_written_once_and_backfilled(settings, finished_jobs):
    db = Database(settings.database_url)
    try:
        with db.session() as session:
            assert session.scalar(select(func.count()).select_from(JobSummary)) == 2 * len(LEARNING_RATES)
        # a job whose summaries are missing (stored by an earlier version) gets them from its runs
        job_id = finished_jobs[0]["id"]
        with db.write() as session:
            before = summaries.compute(session, job_id)
            session.execute(delete(JobSummary).where(JobSummary.job_id == job_id))
            after = summaries.store(session, job_id)
        assert {a: s.final_mean for a, s in before.items()} == {a: s.final_mean for a, s in after.items()}
        spec = make_spec("single", ["uniform", "mgrao-max"], seeds=3, episodes=15, overrides={"learning_rate": 0.3})
        direct = run_experiment(spec).summary()
        assert after["mgrao-max"].final_mean == pytest.approx(direct["mgrao-max"].final_mean, rel=1e-12)
    finally:
        db.dispose()


# ---- the plan of a page -----------------------------------------------------------------------

def page_query(db: Database, **listing) -> tuple[str, object]:
    """The SQL and parameters with which crud.list_jobs reads a page (the statement with ORDER BY)."""
    seen = listing_statements(db, **listing)
    assert len(seen) == 1, seen
    return seen[0]


def plan(db: Database, statement: str, parameters: object) -> str:
    """The database's plan of the statement; on PostgreSQL with sorting and whole-table scans priced out,
    so that an index that can give the order is taken whatever the table's size."""
    with db.engine.connect() as connection:
        if db.engine.dialect.name == "sqlite":
            rows = connection.exec_driver_sql(f"EXPLAIN QUERY PLAN {statement}", parameters).all()
            return "\n".join(str(row[-1]) for row in rows)
        connection.exec_driver_sql("SET enable_sort = off")
        connection.exec_driver_sql("SET enable_seqscan = off")
        rows = connection.exec_driver_sql(f"EXPLAIN {statement}", parameters).all()
        return "\n".join(row[0] for row in rows)


@pytest.mark.parametrize(("sort", "status"), [("-created_at", None), ("created_at", None), ("name", None),
                                              ("-name", None), ("-created_at", "queued")])
def test_a_page_by_a_column_reads_an_index_in_order_and_sorts_nothing(db, sort, status):
    """A page sorted by a column that has an index with the id (never null) reads that index from the
    cursor and stops: no sort of every matching job for each page (100 ms a page at 10,000 jobs)."""
    spec = make_spec("single", seeds=1, episodes=5)
    with db.write() as session:
        for i in range(30):
            crud.create_job(session, spec=spec, name=f"job {i % 7}")
    listing = {"sort": sort, "limit": 5} | ({"status": status} if status else {})
    with db.session() as session:
        _first, cursor, _total = crud.list_jobs(session, **listing)
    assert cursor is not None
    for where in (listing, listing | {"cursor": cursor}):
        text = plan(db, *page_query(db, **where))
        if db.engine.dialect.name == "sqlite":
            assert "TEMP B-TREE" not in text and "INDEX ix_jobs_" in text, (where, text)
        else:
            assert "Sort" not in text and "ix_jobs_" in text, (where, text)
