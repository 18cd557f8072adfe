"""A number given as text is plain decimal or exponent notation, in the API, the command line and studies alike.

Issue 47, item 9: Python's ``float()`` read ``"1_0"`` as 10 and the Arabic-Indic ``"\u0663"`` as 3, and a job
stored them so (``/api/jobs/batch`` too). One rule (``mgrao_core.params.number_from_text``), on SQLite and
PostgreSQL.
"""

from __future__ import annotations

import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient

from mgrao_cli.main import cli

JOB = {"system": "single", "seeds": 1, "episodes": 2}
STUDY = {"name": "s", "base": JOB, "space": {"learning_rate": {"values": [0.1, 0.2]}},
         "objective": {"configuration": "mgrao-max", "metric": "final_mean"}}
TEXTS = ["1_0", "\u0663", "\uff13", "0x3"]


def only_detail(answer) -> dict:
    assert answer.status_code == 422, answer.text
    [detail] = answer.json()["detail"]
    return detail


@pytest.mark.parametrize("text", TEXTS)
def test_text_that_float_reads_but_is_no_plain_number_is_refused(client: TestClient, text: str) -> None:
    answers = {
        "task_need": client.post("/api/jobs", json=JOB | {"params": {"task_need": text}}),
        "jobs[1].n_parents": client.post("/api/jobs/batch", json={"jobs": [
            JOB, JOB | {"params": {"n_parents": text}}]}),
        "base.params.task_need": client.post("/api/studies", json=STUDY | {
            "base": JOB | {"params": {"task_need": text}}}),
        "space.task_need.values[1]": client.post("/api/studies", json=STUDY | {
            "space": {"task_need": {"values": ["1", text]}}}),
        "n_parents": client.post("/api/systems/saved", json={"name": "plain", "base": "single",
                                                                     "params": {"n_parents": text}}),
    }
    for field, answer in answers.items():
        detail = only_detail(answer)
        assert detail["field"] == field, detail
        assert "plain decimal or exponent notation" in detail["msg"] and repr(text) in detail["msg"], detail
    assert client.get("/api/jobs").json()["count"] == 0  # nothing stored
    assert client.get("/api/systems/saved").json() == []


def test_plain_text_numbers_are_still_read(client: TestClient) -> None:
    answer = client.post("/api/jobs", json=JOB | {"params": {"task_need": "2.5e-1", "n_parents": " 12 "}})
    assert answer.status_code == 202, answer.text
    assert (answer.json()["params"]["task_need"], answer.json()["params"]["n_parents"]) == (0.25, 12)


@pytest.mark.parametrize("text", TEXTS)
def test_the_command_line_set_follows_the_rule(text: str) -> None:
    ran = CliRunner().invoke(cli, ["run", "--system", "single", "--seeds", "1", "--episodes", "2",
                                   "--set", f"task_need={text}"])
    assert ran.exit_code != 0
    assert "task_need: must be a number in plain decimal or exponent notation" in ran.output, ran.output
