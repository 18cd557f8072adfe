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


BIDI = {"\u202a": "LRE", "\u202b": "RLE", "\u202c": "PDF", "\u202d": "LRO", "\u202e": "RLO",
        "\u2066": "LRI", "\u2067": "RLI", "\u2068": "FSI", "\u2069": "PDI"}
STUDY = {"base": JOB, "space": {"learning_rate": {"values": [0.1, 0.2]}},
         "objective": {"configuration": "mgrao-max", "metric": "final_mean"}}
EXTERNAL = {"label": "my-learner", "system": "single", "seeds": 1, "episodes": 2}
READ_TEXT = [  # every text field that refuses ESC: (method, path, body of the character, field); {id} is a job's
    ("POST", "/api/jobs", lambda ch: JOB | {"name": f"invoice{ch}fdp.exe"}, "name"),
    ("POST", "/api/jobs", lambda ch: JOB | {"tags": ["ok", f"a{ch}b"]}, "tags[1]"),
    ("POST", "/api/jobs", lambda ch: JOB | {"notes": f"line\n{ch}x"}, "notes"),
    ("POST", "/api/jobs/batch", lambda ch: {"jobs": [JOB, JOB | {"name": f"{ch}x"}]}, "jobs[1].name"),
    ("PATCH", "/api/jobs/{id}", lambda ch: {"name": f"a{ch}"}, "name"),
    ("PATCH", "/api/jobs/{id}", lambda ch: {"tags": [f"{ch}t"]}, "tags[0]"),
    ("PATCH", "/api/jobs/{id}", lambda ch: {"notes": f"x{ch}"}, "notes"),
    ("POST", "/api/studies", lambda ch: STUDY | {"name": f"s{ch}"}, "name"),
    ("POST", "/api/external-runs", lambda ch: EXTERNAL | {"name": f"r{ch}"}, "name"),
    ("POST", "/api/external-runs", lambda ch: EXTERNAL | {"tags": [f"r{ch}"]}, "tags[0]"),
    ("POST", "/api/external-runs", lambda ch: EXTERNAL | {"notes": f"r{ch}"}, "notes"),
    ("POST", "/api/systems/saved", lambda ch: {"name": "mine", "base": "single", "description": f"d{ch}"},
     "description"),
]


@pytest.mark.parametrize(("method", "path", "body", "field"), READ_TEXT,
                         ids=[f"{m} {p} {f}" for m, p, _, f in READ_TEXT])
def test_bidirectional_controls_are_refused_wherever_escape_is(client: TestClient, method: str, path: str,
                                                              body, field: str) -> None:
    # issue 47, item 11: U+202A-U+202E and U+2066-U+2069 reorder what a reader sees ("invoice<RLO>fdp.exe"
    # reads "invoiceexe.pdf"); they were stored while ESC, BEL and NUL were refused
    job = submit(client, name="kept", tags=["kept"])
    url = path.format(id=job["id"])
    escape = client.request(method, url, json=body("\x1b"))
    assert escape.status_code == 422 and escape.json()["detail"][0]["field"] == field, escape.text
    for ch, abbreviation in BIDI.items():
        answer = client.request(method, url, json=body(ch))
        assert answer.status_code == 422, (abbreviation, answer.text)
        [detail] = answer.json()["detail"]
        assert detail["field"] == field, detail
        assert detail["msg"].startswith(f"{field}: must not contain bidirectional controls ({abbreviation}, "
                                        f"U+{ord(ch):04X}, at character "), detail
    assert client.get("/api/jobs").json()["count"] == 1  # nothing stored, nothing changed
    after = client.get(f"/api/jobs/{job['id']}").json()
    assert (after["name"], after["tags"], after["notes"]) == ("kept", ["kept"], "")
    assert client.get("/api/studies").json()["count"] == 0 and client.get("/api/systems/saved").json() == []


def test_the_schema_refuses_bidirectional_controls_too(client: TestClient) -> None:
    schema = client.get("/openapi.json").json()["components"]["schemas"]
    for model, field in (("JobCreate", "name"), ("JobCreate", "notes"), ("JobPatch", "tags"),
                         ("SavedSystemIn", "description"), ("ExternalRunCreate", "tags")):
        entry = schema[model]["properties"][field]
        entry = entry.get("anyOf", [entry])[0]
        pattern = re.compile(entry.get("items", entry)["pattern"])
        assert pattern.search("plain text"), (model, field)
        for ch in BIDI:
            assert not pattern.search(f"a{ch}b"), (model, field, BIDI[ch])
