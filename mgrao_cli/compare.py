"""``mgrao compare 3,4,9``: stored jobs compared as a paper would print them, from a running service.

The statistics are the service's (``GET /api/compare/statistics``, docs/statistics.md), rendered by it: per
system and configuration ``n_paired``, the final mean and % from uniform with their 95% intervals, the
aggregates over systems with stratified bootstrap intervals, and the protocol; ``--format json`` prints the
whole answer (scores, profiles, P(X > Y), the paired tests) and nothing else on stdout.
"""

from __future__ import annotations

import sys
import urllib.parse

import click

from mgrao_cli.studies import TOKEN_OPTION, URL_OPTION, Api
from mgrao_core.statistics.bootstrap import MAX_REPETITIONS
from mgrao_core.statistics.report import FORMATS

TABLE_REPETITIONS = 10_000
"""Bootstrap repetitions of a printed comparison unless asked otherwise (the dashboard's answers take 2,000)."""


def job_ids(_ctx: click.Context, _param: click.Parameter, value: str) -> str:
    """``3,4,9`` as the service takes it, or a usage error naming the argument."""
    parts = [p.strip() for p in value.split(",") if p.strip()]
    if not parts or not all(p.isascii() and p.isdigit() for p in parts):
        raise click.BadParameter(f"give job ids separated by commas, e.g. 3,4,9 (got {value!r})")
    return ",".join(parts)


@click.command("compare")
@click.argument("jobs", metavar="JOB_IDS", callback=job_ids)
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="table", show_default=True,
              help="table (text), csv (numbers, protocol in # lines), json (the whole answer), latex (a table).")
@click.option("--reps", type=click.IntRange(1, MAX_REPETITIONS), default=TABLE_REPETITIONS, show_default=True,
              help="Bootstrap repetitions of the aggregates' and P(X > Y)'s intervals.")
@click.option("--seed", type=click.IntRange(0, 2**32 - 1), default=0, show_default=True,
              help="The bootstrap's seed.")
@click.option("--aggregate", metavar="JOB_IDS", callback=lambda ctx, param, value: value and job_ids(ctx, param, value),
              help="Where a system has several worlds among the jobs (other episodes or parameters): the jobs whose "
                   "worlds stand for their systems in the aggregates, e.g. 4.")
@URL_OPTION
@TOKEN_OPTION
def compare(jobs: str, fmt: str, reps: int, seed: int, aggregate: str | None, url: str, token: str | None) -> None:
    """Compare stored jobs (JOB_IDS: 3,4,9): per-system tables, aggregates across systems, the protocol."""
    query = urllib.parse.urlencode({"jobs": jobs, "reps": reps, "seed": seed, "format": fmt}
                                   | ({"aggregate": aggregate} if aggregate else {}))
    answer = Api(url, token).read("GET", f"/api/compare/statistics?{query}", timeout=600)
    sys.stdout.write(answer.decode())
    if not answer.endswith(b"\n"):
        sys.stdout.write("\n")
