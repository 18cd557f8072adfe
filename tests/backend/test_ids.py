"""Job ids are bounded to a 64-bit integer everywhere: path ids, cursors and compare lists."""

from __future__ import annotations

import base64
import json

import pytest
from fastapi.testclient import TestClient

from backend.store.models import MAX_JOB_ID

JSON = {"Content-Type": "application/json"}
TOO_BIG = 2**63
ID_ROUTES = [
    ("get", "/api/jobs/{id}"), ("patch", "/api/jobs/{id}"), ("delete", "/api/jobs/{id}"),
    ("post", "/api/jobs/{id}/cancel"), ("get", "/api/jobs/{id}/results"), ("get", "/api/jobs/{id}/episodes"),
]


def call(client: TestClient, method: str, path: str):
    kwargs: dict = {"json": {"name": "x"}} if method == "patch" else {"headers": JSON}
    return client.request(method.upper(), path, **kwargs)


def only_detail(response) -> dict:
    body = response.json()
    assert len(body["detail"]) == 1, body
    return body["detail"][0]


@pytest.mark.one_database
@pytest.mark.parametrize(("method", "path"), ID_ROUTES)
@pytest.mark.parametrize("bad", [TOO_BIG, 10**30, 0])
def test_path_id_out_of_range_is_422_naming_job_id(client: TestClient, method: str, path: str, bad: int) -> None:
    response = call(client, method, path.format(id=bad))
    assert response.status_code == 422, response.text
    detail = only_detail(response)
    assert detail["loc"] == ["path", "job_id"] and detail["field"] == "job_id"
    assert detail["msg"].startswith("job_id: ")
    assert (str(MAX_JOB_ID) if bad > 0 else "1") in detail["msg"]


@pytest.mark.parametrize(("method", "path"), ID_ROUTES)
@pytest.mark.parametrize("text", ["-1", "1.0", "1e3", "+1", "0x1", "١٢", " 1"])
def test_a_path_id_that_is_not_plain_digits_names_no_job(client: TestClient, method: str, path: str,
                                                         text: str) -> None:
    # "1.0" must not reach job 1 (a DELETE of /api/jobs/1.0 once deleted job 1)
    submitted = client.post("/api/jobs", json={"system": "single", "seeds": 1, "episodes": 2}).json()
    assert submitted["id"] == 1
    response = call(client, method, path.format(id=text))
    assert response.status_code in (404, 405), response.text  # no job route; 405 from the dashboard's files
    job = client.get("/api/jobs/1").json()
    assert (job["name"], job["status"]) == ("", "queued")  # untouched


@pytest.mark.parametrize(("method", "path"), ID_ROUTES)
def test_largest_id_is_well_formed_and_absent(client: TestClient, method: str, path: str) -> None:
    response = call(client, method, path.format(id=MAX_JOB_ID))
    assert response.status_code == 404, response.text
    assert response.json() == {"detail": f"job {MAX_JOB_ID} not found"}


def cursor(*content: object) -> str:
    return base64.urlsafe_b64encode(json.dumps(list(content)).encode()).decode().rstrip("=")


@pytest.mark.one_database
@pytest.mark.parametrize("after", [TOO_BIG, -TOO_BIG - 1, 0])
def test_crafted_cursor_with_an_id_out_of_range_is_422(client: TestClient, after: int) -> None:
    response = client.get("/api/jobs", params={"sort": "name", "cursor": cursor("name", "a", after)})
    assert response.status_code == 422, response.text
    detail = only_detail(response)
    assert detail["field"] == "cursor" and detail["loc"] == ["query", "cursor"]
    assert detail["msg"].startswith("cursor: ") and str(MAX_JOB_ID) in detail["msg"]


def test_cursor_with_the_largest_id_pages_normally(client: TestClient) -> None:
    response = client.get("/api/jobs", params={"sort": "name", "cursor": cursor("name", "a", MAX_JOB_ID)})
    assert response.status_code == 200 and response.json()["data"] == []


@pytest.mark.one_database
@pytest.mark.parametrize(
    ("jobs", "needle"),
    [(f"1,{TOO_BIG}", str(MAX_JOB_ID)), ("0", str(MAX_JOB_ID)), ("9" * 900, str(MAX_JOB_ID)),
     ("\u0661\u0662", "digits 0-9"), ("1,\u0663", "digits 0-9"), ("\uff11", "digits 0-9"), ("-1", "digits 0-9")],
)
def test_compare_ids_are_ascii_digits_in_range(client: TestClient, jobs: str, needle: str) -> None:
    response = client.get("/api/compare", params={"jobs": jobs})
    assert response.status_code == 422, response.text
    detail = only_detail(response)
    assert detail["field"] == "jobs" and detail["loc"] == ["query", "jobs"]
    assert detail["msg"].startswith("jobs: ") and needle in detail["msg"]


def test_compare_with_the_largest_id_is_404(client: TestClient) -> None:
    response = client.get("/api/compare", params={"jobs": str(MAX_JOB_ID)})
    assert response.status_code == 404, response.text


@pytest.mark.one_database
def test_a_cursor_whose_id_is_a_boolean_is_422(client: TestClient) -> None:
    response = client.get("/api/jobs", params={"cursor": cursor("-created_at", "2020-01-01", True)})
    assert response.status_code == 422, response.text
    assert only_detail(response)["field"] == "cursor"
