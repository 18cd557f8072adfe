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
systems. Its listings link to them (backend/api/links.py), so the stateful phase follows real ids
to every operation on them instead of guessing ids that do not exist. Hypothesis ends a stateful
run at the first scenario whose replay the API's changed state makes inconsistent (a job another
scenario deleted), after tens of scenarios; ROUNDS more stateful runs with other seeds go further.
The test prints the links each run covered (as Schemathesis counts them), the union, and the share
of answers per status class.
"""

from __future__ import annotations

import base64
import json
import os
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

import httpx
import pytest
from backend_helpers import JSON, TOKEN, Service

from mgrao_cli.supervisor import stop_processes

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = 10
SEED = 1
ROUNDS = 5  # more stateful runs, seeds SEED + 1 .. SEED + ROUNDS
DEADLINE_S = 600
MIN_LINKS_COVERED = 60  # of about 270; a run of the whole suite covers 100 to 150 (docs/api.md, "Links")


@pytest.mark.slow
def test_schemathesis_finds_no_failure(service: Service) -> None:
    token = service.db_url.startswith("postgresql")
    headers = {"Authorization": f"Bearer {TOKEN}"} if token else {}
    if token:
        service.env["MGRAO_API_TOKEN"] = TOKEN
    service.start_server()
    worker = service.start_worker()
    seed(service, headers)
    stop_processes([worker], 30)  # what Schemathesis queues stays queued: cancel answers 200, results 409
    before = written_state()
    storage = service.tmp_path / "hypothesis"  # Hypothesis's own Unicode tables go where this says
    covered: set[str] = set()
    statuses: Counter[tuple[str, int]] = Counter()
    for round_ in range(ROUNDS + 1):
        phases = [] if round_ == 0 else ["--phases", "stateful"]
        report = service.tmp_path / f"schemathesis-{round_}.ndjson"
        output = schemathesis(service, SEED + round_, [*phases, "--report", "ndjson", "--report-ndjson-path",
                                                       str(report)], storage, token)
        links = re.search(r"API Links: +(\d+) covered / (\d+) selected / (\d+) total.*", output)
        assert links, f"no stateful phase in round {round_}:\n{output[-5000:]}"
        covered |= links_covered(report, statuses)
        print(f"schemathesis round {round_} ({'all phases' if round_ == 0 else 'stateful'}): {links.group(0)}")
    total = int(links.group(3))
    answers = sum(statuses.values())
    shares = {f"{kind}xx": round(100 * n / answers, 1) for kind, n in _by_class(statuses).items() if n}
    print(f"schemathesis ({service.db_url.split(':')[0]}, token {token}): {len(covered)} of {total} links covered "
          f"in {ROUNDS + 1} runs; {answers} answers, % per class {shares}; stateful phase only "
          f"{_stateful_shares(statuses)}")
    assert len(covered) >= MIN_LINKS_COVERED, sorted(covered)
    # run from the repository root, it keeps nothing there (schemathesis.toml: no example database, no cache),
    # and with Hypothesis's storage elsewhere nothing but its Unicode tables is kept there either
    assert written_state() == before, f"schemathesis wrote into the checkout: {written_state() - before}"
    assert {p.name for p in storage.iterdir()} <= {"unicode_data", ".gitignore"}, list(storage.rglob("*"))


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
    """Real resources of every kind, the jobs and studies run to the end by the worker."""
    client = httpx.Client(base_url=service.base, headers=JSON | headers, timeout=30)

    def ok(answer: httpx.Response) -> dict:
        assert answer.is_success, f"{answer.request.method} {answer.request.url}: {answer.status_code} {answer.text}"
        return answer.json()

    for name, base in (("seeded", "single"), ("seeded-multi", "multi")):
        ok(client.post("/api/systems/saved", json={"name": name, "base": base, "params": {"n_types": 8}}))
    jobs = [ok(client.post("/api/jobs", json={"system": system, "algorithms": ["uniform", "mgrao-1:1", "mgrao-max"],
                                              "seeds": 3, "episodes": 40, "name": f"seeded {system}",
                                              "tags": ["seeded"]}))["id"]
            for system in ("single", "seeded", "volatile", "seeded-multi")]
    studies = [ok(client.post("/api/studies", json={
        "name": f"seeded {i}", "method": "grid",
        "base": {"system": "single", "algorithms": ["uniform", "mgrao-max"], "seeds": 2, "episodes": 15},
        "space": {"learning_rate": {"low": 0.05, "high": 0.2, "steps": 2}},
        "objective": {"configuration": "mgrao-max", "metric": "pct_from_uniform", "direction": "maximize"},
        "max_trials": 4, "max_in_flight": 2}))["study"]["id"] for i in range(3)]
    for label, sent, close in (("closed-learner", 5, True), ("half-sent", 2, False), ("unsent", 0, False)):
        run_id = ok(client.post("/api/external-runs", json={"label": label, "system": "single", "seeds": 2,
                                                            "episodes": 5}))["job"]["id"]
        if sent:
            ok(client.post(f"/api/external-runs/{run_id}/batches", json={"key": "first", "utilities": [
                {"seed": s, "values": [1.0 + s, 2.0, 3.0, 4.0, 5.0][:sent]} for s in (0, 1)]}))
        if close:
            ok(client.post(f"/api/external-runs/{run_id}/close"))

    def finished() -> bool:
        done = [client.get(f"/api/jobs/{job}").json()["status"] for job in jobs]
        assert "failed" not in done, done
        return all(s == "succeeded" for s in done) and all(
            client.get(f"/api/studies/{study}").json()["study"]["status"] != "running" for study in studies)

    service.wait_for(finished, timeout=240, what="the seeded jobs and studies to finish")
    client.close()


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


def _stateful_shares(statuses: Counter[tuple[str, int]]) -> dict[str, float]:
    stateful = Counter({key: n for key, n in statuses.items() if key[0] == "stateful"})
    total = sum(stateful.values()) or 1
    return {f"{kind}xx": round(100 * n / total, 1) for kind, n in _by_class(stateful).items() if n}


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
    assert _stateful_shares(statuses) == {"2xx": 50.0, "4xx": 50.0}
