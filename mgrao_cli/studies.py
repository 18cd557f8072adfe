"""``mgrao study run FILE.json`` and ``mgrao study show ID``: studies through a running service's REST API.

A study's trials are jobs of the service, so these commands talk to it (``mgrao serve``, or a
cluster's API) rather than simulate in the shell: a study submitted here is the one the
dashboard shows, and it keeps running if the command is interrupted.
"""

from __future__ import annotations

import json
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

import click

DEFAULT_URL = "http://127.0.0.1:8000"
URL_OPTION = click.option("--url", envvar="MGRAO_URL", default=DEFAULT_URL, show_default=True,
                          help="The service's base URL (env MGRAO_URL).")
TOKEN_OPTION = click.option("--token", envvar="MGRAO_API_TOKEN", default=None,
                            help="The service's API token, if it has one (env MGRAO_API_TOKEN); sent with "
                                 "every request, reads too.")
TOP_OPTION = click.option("--top", default=5, show_default=True, type=click.IntRange(1, 1000),
                          help="How many of the best trials to print.")
ENDED = ("succeeded", "failed", "cancelled")


class Api:
    """The few calls the commands make, with errors as click exceptions that say what to do."""

    def __init__(self, url: str, token: str | None) -> None:
        self.url, self.token = url.rstrip("/"), token

    def call(self, method: str, path: str, body: Any = None) -> Any:
        """The JSON answer of ``method path`` with ``body``."""
        raw = self.read(method, path, body)
        return json.loads(raw) if raw else None  # 204: no content

    def read(self, method: str, path: str, body: Any = None, timeout: float = 60) -> bytes:
        """The answer's bytes of ``method path`` with ``body``."""
        data = None if body is None else json.dumps(body).encode()
        request = urllib.request.Request(self.url + path, data=data, method=method,
                                         headers={"Content-Type": "application/json", "Accept": "application/json"})
        if self.token:
            request.add_header("Authorization", f"Bearer {self.token}")
        try:
            with urllib.request.urlopen(request, timeout=timeout) as response:  # noqa: S310 - the user's own service
                return response.read()
        except urllib.error.HTTPError as error:
            raise click.ClickException(_http_error(error)) from None
        except (urllib.error.URLError, OSError) as error:
            reason = getattr(error, "reason", error)
            raise click.ClickException(f"no MG-RAO service answers at {self.url} ({reason}): start one with "
                                       "`mgrao serve`, or give its address with --url") from None


def _http_error(error: urllib.error.HTTPError) -> str:
    try:
        detail = json.loads(error.read()).get("detail")
    except (ValueError, AttributeError):
        detail = None
    if isinstance(detail, list):  # validation errors: one line each, naming the field
        return "the service refused the request:\n" + "\n".join(f"  {d.get('msg', d)}" for d in detail)
    if error.code == 401:
        return "the service needs its API token: pass --token or set MGRAO_API_TOKEN"
    return f"{error.code} {error.reason}: {detail or ''}".rstrip(": ")


def _ended(study: dict[str, Any]) -> int:
    return sum(study["trials"].get(status, 0) for status in ENDED)


def _value(value: float | None) -> str:
    return "-" if value is None else f"{value:.4g}"


def _best(trials: list[dict[str, Any]], direction: str, top: int) -> list[dict[str, Any]]:
    scored = [t for t in trials if t["status"] == "succeeded" and t["value"] is not None]
    scored.sort(key=lambda t: (-t["value"] if direction == "maximize" else t["value"], t["number"]))
    return scored[:top]


def _report(answer: dict[str, Any], url: str, top: int) -> None:
    study, trials = answer["study"], answer["trials"]
    objective = study["objective"]
    what = objective["metric"] + (f" of {objective['configuration']}" if objective.get("configuration") else "")
    counts = ", ".join(f"{count} {status}" for status, count in sorted(study["trials"].items()))
    click.echo(f"study {study['id']} {study['name']!r}: {study['method']}, {study['status']}; "
               f"{counts or 'no trials yet'} of {study['planned']} planned")
    click.echo(f"objective: {objective['direction']} {what}")
    best = _best(trials, objective["direction"], top)
    if best:
        names = list(best[0]["params"])
        header = ["trial", *names, "objective", "95% CI", "jobs"]
        rows = [[str(t["number"]), *(_param(t["params"].get(n)) for n in names), _value(t["value"]),
                 f"[{_value(t['ci95'][0])}, {_value(t['ci95'][1])}]" if t["ci95"] else "-",
                 " ".join(map(str, t["job_ids"]))] for t in best]
        widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
        click.echo(f"best {len(best)} trials:")
        for row in [header, *rows]:
            click.echo("  " + "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)))
    failed = [t for t in trials if t["status"] == "failed"]
    if failed:
        click.echo(f"{len(failed)} failed trials (re-run them with POST /api/studies/{study['id']}/rerun-failed "
                   f"or the dashboard's \"Re-run failed\"); the first: {failed[0]['error']}")
    click.echo(f"dashboard: {url.rstrip('/')}/#/studies/{study['id']}")


def _param(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


@click.group()
def study() -> None:
    """Studies: parameter sweeps and searches, run as jobs of a service (see docs/studies.md)."""


@study.command("run")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@URL_OPTION
@TOKEN_OPTION
@TOP_OPTION
@click.option("--detach", is_flag=True, help="Submit and print the study's id without waiting.")
@click.option("--poll", default=1.0, show_default=True, type=click.FloatRange(0.05, 60),
              help="Seconds between progress checks.")
def run_study(file: Path, url: str, token: str | None, top: int, detach: bool, poll: float) -> None:
    """Submit the study in FILE.json to the service, follow it with a progress bar, print the best trials.

    Interrupting the command leaves the study running in the service: `mgrao study show ID`.
    """
    try:
        definition = json.loads(file.read_text())
    except (ValueError, UnicodeDecodeError) as error:
        raise click.ClickException(f"{file} is not JSON: {error}") from None
    api = Api(url, token)
    answer = api.call("POST", "/api/studies", definition)
    study_id, planned = answer["study"]["id"], answer["study"]["planned"]
    click.echo(f"study {study_id} submitted: {planned} trials planned", err=True)
    if detach:
        click.echo(study_id)
        return
    try:
        with click.progressbar(length=planned, label=f"study {study_id}", file=sys.stderr,
                               show_pos=True) as bar:
            while True:
                current = api.call("GET", f"/api/studies/{study_id}")
                bar.update(_ended(current["study"]) - bar.pos)
                if current["study"]["status"] != "running":
                    break
                time.sleep(poll)
    except KeyboardInterrupt:
        click.echo(f"\nstudy {study_id} goes on in the service: `mgrao study show {study_id}`", err=True)
        sys.exit(130)
    _report(current, url, top)


@study.command("show")
@click.argument("study_id", type=click.IntRange(1, 2**53))
@URL_OPTION
@TOKEN_OPTION
@TOP_OPTION
@click.option("--json", "as_json", is_flag=True, help="Print the service's whole answer as JSON.")
def show_study(study_id: int, url: str, token: str | None, top: int, as_json: bool) -> None:
    """Print a study's state and its best trials."""
    answer = Api(url, token).call("GET", f"/api/studies/{study_id}")
    if as_json:
        click.echo(json.dumps(answer, indent=1))
        return
    _report(answer, url, top)
