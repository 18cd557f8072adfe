"""Text a person names something with is one text however it was typed, and holds no control characters.

Issue 30, points 11 and 13: "é" as NFC and as NFD were two tags of one job; control characters and terminal
escapes were stored in names; the OpenAPI document allowed tags the server refused (" ", "\\t", "\\u3000").
On SQLite and PostgreSQL alike, through the API.
"""

from __future__ import annotations

import re
import unicodedata

import pytest
from fastapi.testclient import TestClient

NFC, NFD = "caf\u00e9", "cafe\u0301"
JOB = {"system": "single", "seeds": 1, "episodes": 2}


def submit(client: TestClient, **body: object) -> dict:
    answer = client.post("/api/jobs", json=JOB | body)
    assert answer.status_code == 202, answer.text
    return answer.json()


def test_names_tags_and_notes_are_stored_in_nfc_so_one_text_is_one_tag(client: TestClient) -> None:
    job = submit(client, name=f"run {NFD}", tags=[NFD], notes=f"first line\n\t{NFD}")
    assert job["name"] == f"run {NFC}" and job["tags"] == [NFC] and job["notes"] == f"first line\n\t{NFC}"
    patched = client.patch(f"/api/jobs/{job['id']}", json={"tags": [NFC, NFD, "other"]}).json()
    assert patched["tags"] == [NFC, "other"]  # the two spellings are one tag
    for typed in (NFC, NFD):  # the tag filter and the search find it however it is typed
        assert [j["id"] for j in client.get("/api/jobs", params={"tag": typed}).json()["data"]] == [job["id"]]
        assert [j["id"] for j in client.get("/api/jobs", params={"q": typed}).json()["data"]] == [job["id"]]


@pytest.mark.parametrize(("body", "field", "code"), [
    ({"name": "red \x1b[31malert"}, "name", "001B"),
    ({"tags": ["ok", "a\tb"]}, "tags[1]", "0009"),
    ({"notes": "bell \x07"}, "notes", "0007"),
    ({"name": "next\u0085line"}, "name", "0085"),
])
def test_control_characters_are_refused_naming_the_field_and_the_character(client: TestClient, body: dict,
                                                                           field: str, code: str) -> None:
    job = submit(client)
    for answer in (client.post("/api/jobs", json=JOB | body), client.patch(f"/api/jobs/{job['id']}", json=body)):
        assert answer.status_code == 422, answer.text
        [detail] = answer.json()["detail"]
        assert detail["field"] == field and f"U+{code}" in detail["msg"], detail
    assert client.get(f"/api/jobs/{job['id']}").json()["name"] == ""  # nothing stored


def test_the_schema_says_which_tags_the_server_takes(client: TestClient) -> None:
    schema = client.get("/openapi.json").json()["components"]["schemas"]
    for model in ("JobPatch", "JobCreate"):
        tags = schema[model]["properties"]["tags"]
        items = (tags.get("anyOf", [tags])[0])["items"]
        pattern = re.compile(items["pattern"])
        for refused in (" ", "\t", "\f", "\u3000", "a\x1bb", ""):
            assert not pattern.search(refused), (model, refused)
        for taken in ("a", " a ", NFC, "two words"):
            assert pattern.search(taken), (model, taken)
    job = submit(client)
    for blank in (" ", "\t", "\f", "\u3000"):  # schema-invalid and refused: what the schema says
        assert client.patch(f"/api/jobs/{job['id']}", json={"tags": [blank]}).status_code == 422
    assert unicodedata.is_normalized("NFC", client.patch(f"/api/jobs/{job['id']}",
                                                         json={"tags": [f" {NFD} "]}).json()["tags"][0])
