"""Schemathesis, an outside judge, against a live ``mgrao serve`` on SQLite and PostgreSQL: no failure.

It reads the service's own OpenAPI document, generates requests from it (valid and invalid, then
sequences along its links) and runs every check on the answers: no server error, only documented
status codes, content types and headers, answers that match their schemas, invalid data refused,
valid data accepted, 405 with Allow for undocumented methods, auth enforced where declared, a
resource just created found, a deleted one gone. Run from the repository root, so that it reads
schemathesis.toml (which says what the document cannot: see there). Bounded: EXAMPLES cases per
operation and phase, fixed seeds. The SQLite service runs without a token (writes need none: the
document says so); the PostgreSQL one with MGRAO_API_TOKEN, the token given to Schemathesis as a
client would send it, so that it also checks that writes without it, or with a wrong one, are refused.

The service holds real resources before Schemathesis starts (:func:`seed`): finished jobs of a preset
and of a saved system, studies with their trials, external runs closed, half-sent and empty, saved
systems, and more of each that only deletions draw on. schemathesis.toml's dictionaries name them (6.:
the test asserts their ids), so most generated requests reach a real resource, and the listings link to
them (backend/api/links.py), so the stateful phase follows real ids to every operation on them.
Hypothesis ends a stateful run at the first scenario whose replay the API's changed state makes
inconsistent (a job another scenario deleted), after tens of scenarios; ROUNDS more stateful runs with
other seeds go further, each on a fresh copy of the seeded database (SQLite's backup, PostgreSQL's
template), so that every run finds what the first found. The test prints the links each run covered
(as Schemathesis counts them), the union, and the share of answers per status class and phase; it
asserts that at least half the links were covered and that at least MIN_DEEP_2XX % of the fuzzing and
stateful phases' answers were 2xx. (The coverage phase's answers are mostly refusals by design: it sends
each limit's value beyond it, and its valid cases give numbers as text, "", and a saved system named
"a", which the schema allows and the service refuses as not a number, not a saved system.)
"""

from __future__ import annotations

import base64
import contextlib
import itertools
import json
import os
import re
import sqlite3
import subprocess
import sys
import tomllib
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from backend_helpers import JSON, TOKEN, Service

from mgrao_cli.supervisor import stop_processes
from tests.support.postgres import PostgresServer

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = 10
SEED = 1
ROUNDS = 5  # more stateful runs, seeds SEED + 1 .. SEED + ROUNDS
DEADLINE_S = 600
MIN_DEEP_2XX = 20.0  # % of the fuzzing and stateful phases' answers (docs/api.md, "Contract tests")
PHASES = ("examples", "coverage", "fuzzing", "stateful")


@pytest.mark.slow
def test_schemathesis_finds_no_failure(service: Service, request: pytest.FixtureRequest) -> None:
    token = service.db_url.startswith("postgresql")
    headers = {"Authorization": f"Bearer {TOKEN}"} if token else {}
    if token:
        service.env["MGRAO_API_TOKEN"] = TOKEN
    service.start_server()
    worker = service.start_worker()
    seed(service, headers)
    # what Schemathesis queues stays queued (cancel answers 200, results 409); every run starts from the seeded state
    stop_processes([worker, service.server], 30)
    copies = contextlib.closing(seeded_copies(service, request))
    before = written_state()
    storage = service.tmp_path / "hypothesis"  # Hypothesis's own Unicode tables go where this says
    covered: set[str] = set()
    statuses: Counter[tuple[str, int]] = Counter()
    with copies as fresh:
        for round_ in range(ROUNDS + 1):
            service.db_url = service.env["MGRAO_DATABASE_URL"] = next(fresh)
            service.start_server()
            phases = [] if round_ == 0 else ["--phases", "stateful"]
            report = service.tmp_path / f"schemathesis-{round_}.ndjson"
            output = schemathesis(service, SEED + round_, [*phases, "--report", "ndjson", "--report-ndjson-path",
                                                           str(report)], storage, token)
            stop_processes([service.server], 30)
            links = re.search(r"API Links: +(\d+) covered / (\d+) selected / (\d+) total.*", output)
            assert links, f"no stateful phase in round {round_}:\n{output[-5000:]}"
            covered |= links_covered(report, statuses)
            print(f"schemathesis round {round_} ({'all phases' if round_ == 0 else 'stateful'}): {links.group(0)}")
    total = int(links.group(3))
    answers = sum(statuses.values())
    shares = {f"{kind}xx": round(100 * n / answers, 1) for kind, n in _by_class(statuses).items() if n}
    deep = _shares(statuses, ("fuzzing", "stateful"))
    print(f"schemathesis ({service.db_url.split(':')[0]}, token {token}): {len(covered)} of {total} links covered "
          f"in {ROUNDS + 1} runs; {answers} answers, % per class {shares}; per phase "
          f"{ {phase: _shares(statuses, (phase,)) for phase in PHASES if any(p == phase for p, _ in statuses)} }")
    assert len(covered) >= total / 2, f"{len(covered)} of {total} links covered: {sorted(covered)}"
    assert deep.get("2xx", 0) >= MIN_DEEP_2XX, f"answers of the fuzzing and stateful phases, % per class: {deep}"
    # run from the repository root, it keeps nothing there (schemathesis.toml: no example database, no cache),
    # and with Hypothesis's storage elsewhere nothing but its Unicode tables is kept there either
    assert written_state() == before, f"schemathesis wrote into the checkout: {written_state() - before}"
    assert {p.name for p in storage.iterdir()} <= {"unicode_data", ".gitignore"}, list(storage.rglob("*"))


def seeded_copies(service: Service, request: pytest.FixtureRequest) -> Iterator[str]:
    """URLs of fresh copies of the service's seeded database (nobody connected), one per run; each dropped after it."""
    seeded = service.db_url
    if seeded.startswith("sqlite"):
        with contextlib.closing(sqlite3.connect(seeded.removeprefix("sqlite:///"))) as source:
            for n in itertools.count():
                with contextlib.closing(sqlite3.connect(service.tmp_path / f"run-{n}.db")) as copy:
                    source.backup(copy)
                yield f"sqlite:///{service.tmp_path / f'run-{n}.db'}"
    server: PostgresServer = request.getfixturevalue("postgres_server")
    while True:
        copy_url = server.create_database(template=seeded)
        try:
            yield copy_url
        finally:
            server.drop_database(copy_url)


def schemathesis(service: Service, seed_: int, extra: list[str], storage: Path, token: bool) -> str:
    """One ``schemathesis run`` with every check (schemathesis.toml); its output, asserted free of failures."""
    # every check is on by default (schemathesis.toml); `--checks all` would override the one it turns off
    command = [sys.executable, "-m", "schemathesis.cli", "run", f"{service.base}/openapi.json",
               "--max-examples", str(EXAMPLES), "--seed", str(seed_), "--workers", "1", "--no-color",
               "--request-timeout", "30", *extra, *(["--header", f"Authorization: Bearer {TOKEN}"] if token else [])]
    try:
        done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=DEADLINE_S, check=False,
                              env=dict(os.environ, HYPOTHESIS_STORAGE_DIRECTORY=str(storage)))
    except subprocess.TimeoutExpired as error:
        raise AssertionError(f"schemathesis (seed {seed_}) did not finish within {DEADLINE_S} s:\n"
                             f"{error.stdout}") from None
    output = done.stdout + done.stderr
    assert f"Configuration:    {ROOT / 'schemathesis.toml'}" in output, output[-5000:]
    counted = re.search(r"(\d+) generated, (.*)", output)
    assert counted, f"no test cases counted:\n{output[-5000:]}"
    assert done.returncode == 0 and "failure" not in counted.group(2), f"seed {seed_}: {counted.group(0)}\n" \
                                                                        f"{output[-20000:]}"
    assert int(counted.group(1)) > 0, output[-5000:]
    return output


def seed(service: Service, headers: dict[str, str]) -> None:
    """Real resources of every kind, the jobs and studies run to the end by the worker, with the ids and names
    that schemathesis.toml's dictionaries give (6.): the first for every operation, the doomed for deletions."""
    client = httpx.Client(base_url=service.base, headers=JSON | headers, timeout=30)

    def ok(answer: httpx.Response) -> dict:
        assert answer.is_success, f"{answer.request.method} {answer.request.url}: {answer.status_code} {answer.text}"
        return answer.json()

    def study(name: str) -> int:
        return ok(client.post("/api/studies", json={
            "name": name, "method": "grid",
            "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 15},
            "space": {"learning_rate": {"low": 0.05, "high": 0.2, "steps": 2}},
            "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform", "direction": "maximize"},
            "max_trials": 4, "max_in_flight": 2}))["study"]["id"]

    names = [ok(client.post("/api/systems/saved", json={"name": name, "base": base, "params": {"n_types": 8}}))["name"]
             for name, base in (("seeded", "single"), ("seeded-multi", "multi"))]
    jobs = [ok(client.post("/api/jobs", json={"system": system, "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"],
                                              "seeds": 3, "episodes": 40, "name": f"seeded {system}",
                                              "tags": ["seeded"]}))["id"]
            for system in ("single", "seeded", "volatile", "seeded-multi")]
    studies = [study(f"seeded {i}") for i in range(3)]  # each makes its two trials' jobs at once
    runs = []
    for label, sent, close in (("closed-learner", 5, True), ("half-sent", 2, False), ("unsent", 0, False)):
        run_id = ok(client.post("/api/external-runs", json={"label": label, "system": "single", "seeds": 2,
                                                            "episodes": 5}))["job"]["id"]
        runs.append(run_id)
        if sent:
            ok(client.post(f"/api/external-runs/{run_id}/batches", json={"key": "first", "utilities": [
                {"seed": s, "values": [1.0 + s, 2.0, 3.0, 4.0, 5.0][:sent]} for s in (0, 1)]}))
        if close:
            ok(client.post(f"/api/external-runs/{run_id}/close"))
    doomed_jobs = [ok(client.post("/api/jobs", json={"system": "single", "algorithms": ["uniform", "mgrao-max"],
                                                     "seeds": 1, "episodes": 5, "name": f"doomed {i}"}))["id"]
                   for i in range(6)]
    doomed_studies = [study(f"doomed {i}") for i in range(2)]
    names += [ok(client.post("/api/systems/saved", json={"name": f"doomed-{i}", "base": "single"}))["name"]
              for i in (1, 2, 3)]
    trials = sorted(set(range(1, 24)) - {*jobs, *runs, *doomed_jobs})
    given = dictionaries()
    assert (names, jobs + trials[:6] + runs, runs, doomed_jobs + trials[6:], studies, doomed_studies) == (
        given["saved-names"] + given["doomed-saved-names"], given["job-ids"], given["external-run-ids"],
        given["doomed-job-ids"], given["study-ids"], given["doomed-study-ids"]), "schemathesis.toml's ids (6.)"
    every_job = [*jobs, *doomed_jobs]
    every_study = [*studies, *doomed_studies]

    def finished() -> bool:
        done = [client.get(f"/api/jobs/{job}").json()["status"] for job in every_job]
        assert "failed" not in done, done
        return all(s == "succeeded" for s in done) and all(
            client.get(f"/api/studies/{study}").json()["study"]["status"] != "running" for study in every_study)

    service.wait_for(finished, timeout=240, what="the seeded jobs and studies to finish")
    assert client.get("/api/jobs", params={"limit": 200}).json()["count"] == 23
    client.close()


def dictionaries() -> dict[str, list]:
    """schemathesis.toml's dictionaries: name to values."""
    with open(ROOT / "schemathesis.toml", "rb") as config:
        return {name: entry["values"] for name, entry in tomllib.load(config)["dictionaries"].items()}


def links_covered(report: Path, statuses: Counter[tuple[str, int]]) -> set[str]:
    """The links a run's stateful phase followed (as Schemathesis counts them); adds its answers to ``statuses``."""
    covered = set()
    for line in report.read_text().splitlines():
        event = json.loads(line).get("ScenarioFinished")
        if not event or "cases" not in event["recorder"]:
            continue
        recorder = event["recorder"]
        for case in recorder["cases"].values():
            if event["phase"] == "stateful" and case.get("transition") and case.get("is_transition_applied"):
                covered.add(case["transition"]["id"])
        for interaction in recorder.get("interactions", {}).values():
            if interaction.get("response"):
                statuses[event["phase"], interaction["response"]["status_code"]] += 1
    return covered


def _by_class(statuses: Counter[tuple[str, int]]) -> Counter[int]:
    return Counter({kind: sum(n for (_, code), n in statuses.items() if code // 100 == kind) for kind in (2, 3, 4, 5)})


def _shares(statuses: Counter[tuple[str, int]], phases: tuple[str, ...]) -> dict[str, float]:
    """The answers of ``phases``, % per status class."""
    chosen = Counter({key: n for key, n in statuses.items() if key[0] in phases})
    total = sum(chosen.values()) or 1
    return {f"{kind}xx": round(100 * n / total, 1) for kind, n in _by_class(chosen).items() if n}


def written_state() -> set[str]:
    """What Hypothesis or Schemathesis could have written under the repository root: their directories' files."""
    return {str(p.relative_to(ROOT)) for name in (".hypothesis", ".schemathesis") if (ROOT / name).exists()
            for p in (ROOT / name).rglob("*")}


def test_the_status_classes_of_a_report_are_counted(tmp_path: Path) -> None:
    """The counting the contract test reports, on a report of two scenarios (one stateful, one link followed)."""
    ok = base64.b64encode(b"{}").decode()
    report = tmp_path / "r.ndjson"
    scenario = {"ScenarioFinished": {"phase": "stateful", "recorder": {
        "cases": {"a": {"value": {}}, "b": {"value": {}, "transition": {"id": "POST /x -> [201] read -> GET /x/{id}"},
                                            "is_transition_applied": True}},
        "interactions": {"a": {"response": {"status_code": 201, "content": {"$base64": ok}}},
                         "b": {"response": {"status_code": 404}}}}}}
    fuzzing = {"ScenarioFinished": {"phase": "fuzzing", "recorder": {
        "cases": {"c": {"value": {}}}, "interactions": {"c": {"response": {"status_code": 422}}}}}}
    report.write_text("\n".join(json.dumps(e) for e in ({"Initialize": {}}, scenario, fuzzing)))
    statuses: Counter[tuple[str, int]] = Counter()
    assert links_covered(report, statuses) == {"POST /x -> [201] read -> GET /x/{id}"}
    assert statuses == Counter({("stateful", 201): 1, ("stateful", 404): 1, ("fuzzing", 422): 1})
    assert _by_class(statuses) == Counter({2: 1, 3: 0, 4: 2, 5: 0})
    assert _shares(statuses, ("stateful",)) == {"2xx": 50.0, "4xx": 50.0}
    assert _shares(statuses, ("fuzzing", "stateful")) == {"2xx": 33.3, "4xx": 66.7}
