"""``mgrao log FILE.csv``: upload a run's episode utilities, computed anywhere, to a service as an external run.

The CSV has a header and the columns ``seed,episode,utility`` (more columns are ignored), episodes counted
from 0; the episode count is inferred (the largest episode + 1) and every seed must have every episode
once. The run is opened with a key made of the file's content and the run's definition, so running the
same command again after an interruption resumes the same run: batches already stored are replays,
nothing is stored twice (docs/platform.md, "Logging runs").
"""

from __future__ import annotations

import csv
import hashlib
import math
from pathlib import Path

import click

from mgrao_cli.experiments import _parse_sets
from mgrao_cli.studies import TOKEN_OPTION, URL_OPTION
from mgrao_client import ApiError, Client, ServiceUnavailable


def read_csv(path: Path) -> tuple[dict[int, list[float]], int]:
    """The utilities of each seed, in episode order, and the episode count, from a ``seed,episode,utility`` CSV.

    Raises:
        click.ClickException: naming the line: a missing column, a value that is not a number (or not
            finite), a negative episode, an episode given twice, a seed missing episodes.
    """
    runs: dict[int, dict[int, float]] = {}
    with path.open(newline="") as handle:
        reader = csv.DictReader(handle)
        missing = {"seed", "episode", "utility"} - set(reader.fieldnames or [])
        if missing:
            raise click.ClickException(f"{path}: the header must name the columns seed,episode,utility (missing "
                                       f"{', '.join(sorted(missing))})")
        for row in reader:
            line = reader.line_num
            try:
                seed, episode, utility = int(row["seed"]), int(row["episode"]), float(row["utility"])
            except (TypeError, ValueError):
                raise click.ClickException(f"{path}:{line}: seed and episode must be whole numbers and utility a "
                                           f"number (got {row.get('seed')!r}, {row.get('episode')!r}, "
                                           f"{row.get('utility')!r})") from None
            if not math.isfinite(utility) or episode < 0 or seed < 0:
                raise click.ClickException(f"{path}:{line}: seed and episode must be >= 0 and utility finite")
            episodes = runs.setdefault(seed, {})
            if episode in episodes:
                raise click.ClickException(f"{path}:{line}: seed {seed} episode {episode} is given twice")
            episodes[episode] = utility
    if not runs:
        raise click.ClickException(f"{path}: no rows")
    count = max(max(e) for e in runs.values()) + 1
    for seed, episodes in sorted(runs.items()):
        if len(episodes) != count:
            absent = next(e for e in range(count) if e not in episodes)
            raise click.ClickException(f"{path}: seed {seed} has {len(episodes)} of the {count} episodes (0-"
                                       f"{count - 1}) the file's longest seed has; episode {absent} is missing")
    return {seed: [episodes[e] for e in range(count)] for seed, episodes in sorted(runs.items())}, count


@click.command("log")
@click.argument("file", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--system", required=True, help="The preset the run's world is (single, multi, volatile, large).")
@click.option("--label", required=True, help="The run's label beside the built-in configurations (my-learner).")
@click.option("--set", "sets", multiple=True, metavar="NAME=VALUE", help="Override a parameter (repeatable).")
@click.option("--name", default="", help="The job's name in the dashboard.")
@click.option("--tag", "tags", multiple=True, help="A tag of the job (repeatable).")
@click.option("--key", default=None, help="The run's open key (default: from the file and the definition).")
@URL_OPTION
@TOKEN_OPTION
def log(file: Path, system: str, label: str, sets: tuple[str, ...], name: str, tags: tuple[str, ...],
        key: str | None, url: str, token: str | None) -> None:
    """Upload FILE.csv (seed,episode,utility) as an external run beside the built-in ones."""
    runs, episodes = read_csv(file)
    params = _parse_sets(sets)
    if key is None:
        digest = hashlib.sha256(file.read_bytes())
        digest.update(repr((label, system, sorted(params.items()))).encode())
        key = f"csv-{digest.hexdigest()[:40]}"
    client = Client(url, token)
    try:
        run = client.open_run(label=label, system=system, episodes=episodes, seeds=list(runs), params=params,
                              name=name or file.stem, tags=tags, key=key)
        click.echo(f"{'resuming' if run.resumed else 'opened'} external run {run.id}: {label} on {system}, "
                   f"{len(runs)} seeds x {episodes} episodes")
        for seed, values in runs.items():
            run.log(seed, values)
        state = run.close()
    except ApiError as error:
        raise click.ClickException(str(error)) from None
    except ServiceUnavailable as error:
        raise click.ClickException(f"{error}: start one with `mgrao serve`, or give its address with --url") from None
    replayed = f" ({run.replayed} already stored)" if run.replayed else ""
    click.echo(f"logged {state['values_stored']:,} episode utilities in {run.batches} batches{replayed}; "
               f"run {run.id} is {state['status']}: {url.rstrip('/')}/#/jobs/{run.id}")
