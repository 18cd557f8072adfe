"""``mgrao run`` and ``mgrao reproduce``: experiments from the shell."""

from __future__ import annotations

import csv
import functools
import io
import json
import math
import os
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import click

import mgrao_core
from mgrao_cli.engine_loading import load_engine
from mgrao_core import ConfigError, MgraoError, make_spec
from mgrao_core.presets import PAPER_SYSTEMS, PRESETS
from mgrao_core.reproduction import DEFAULT_SEEDS, READINGS, reproduction_table
from mgrao_core.reproduction import reproduce as run_reproduction
from mgrao_core.spec import MAX_SEED_VALUE
from mgrao_core.statistics.report import deciding_digits, text_table
from mgrao_core.statistics.sequential import Verdict, coverage_of, parse_until, run_until, until_spec

PROGRESS_BAR_WORK = 20_000_000
"""Atomic tasks above which a run draws a progress bar (about a second of simulation)."""


def _parse_sets(values: tuple[str, ...]) -> dict[str, str]:
    overrides = {}
    for item in values:
        name, sep, value = item.partition("=")
        if not sep or not name:
            raise click.BadParameter(f"expected name=value, got {item!r}", param_hint="--set")
        overrides[name.strip()] = value.strip()
    return overrides


def read_params_file(path: str) -> tuple[str | None, dict[str, Any]]:
    """A file of parameter values: a JSON object of them, or a saved system's file (``base`` and ``params``).

    Lists and event lists are JSON values there as in the API (``"schedule": [{"episode": 50, ...}]``).
    Returns the saved system's base preset (None for a plain object) and the parameter values.
    """
    try:
        with open(path, encoding="utf-8") as handle:
            data = json.load(handle)
    except OSError as error:
        raise click.BadParameter(f"cannot read {path}: {error.strerror}", param_hint="--params-file") from None
    except ValueError as error:
        raise click.BadParameter(f"{path} is not JSON: {error}", param_hint="--params-file") from None
    if not isinstance(data, dict):
        raise click.BadParameter(f"{path} must hold a JSON object of parameter values", param_hint="--params-file")
    if "base" in data and isinstance(data.get("params"), dict):  # a saved system's file (mgrao systems export)
        return str(data["base"]), data["params"]
    return None, data


def _fmt(value: float | None, digits: int = 1) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    return f"{value:.{digits}f}"


def _interval(pair: list[float] | tuple[float, float] | None, digits: int = 1) -> str:
    if not pair or any(v is None or math.isnan(v) for v in pair):
        return "-"
    return f"[{pair[0]:.{digits}f}, {pair[1]:.{digits}f}]"


@contextmanager
def _progress(label: str, show: bool) -> Iterator[Any]:
    if not show:
        yield lambda fraction: None
        return
    with click.progressbar(length=1000, label=label, file=sys.stderr, show_percent=True) as bar:
        def update(fraction: float) -> None:
            bar.update(int(round(fraction * 1000)) - bar.pos)

        yield update


def _compile_notices(bar: bool) -> Callable[[Any], None]:
    """A run's ``on_compile``: each notice on a line of stderr, under a progress bar drawn there already."""
    def say(notice: Any) -> None:
        click.echo(("\n" if bar and notice.seconds is None else "") + f"mgrao: {notice.message}", err=True)

    return say


def _emit(text: str, out: str | None) -> None:
    if out:
        try:
            with open(out, "w", encoding="utf-8") as handle:
                handle.write(text if text.endswith("\n") else text + "\n")
        except OSError as error:
            raise click.FileError(out, hint=error.strerror or str(error)) from None
        click.echo(f"wrote {out}", err=True)
    else:
        click.echo(text.rstrip("\n"))


def _fail(error: MgraoError) -> None:
    raise click.UsageError(str(error)) from error


def _check_out(_ctx: click.Context, param: click.Parameter, value: str | None) -> str | None:
    """``--out``: the file's directory must exist and be writable, checked before any simulation."""
    if value is None:
        return None
    directory = os.path.dirname(os.path.abspath(value))
    if not os.path.isdir(directory):
        raise click.BadParameter(f"directory {directory!r} does not exist", param=param)
    if not os.path.exists(value) and not os.access(directory, os.W_OK):
        raise click.BadParameter(f"directory {directory!r} is not writable", param=param)
    return value


def _algorithm_labels(algorithms: str | None) -> list[str] | None:
    """The ``--algorithms`` labels; None (the system's defaults) only when the option is absent."""
    if algorithms is None:
        return None
    if not algorithms.strip():
        raise click.BadParameter("is empty: give comma-separated labels such as uniform,mgrao-max, "
                                 "or leave the option out for the system's defaults", param_hint="--algorithms")
    return [a.strip() for a in algorithms.split(",")]


def _seed_range(count: int, first: int) -> int | list[int]:
    """``count`` seeds from ``first`` (the count itself when ``first`` is 0, so errors name it plainly)."""
    if first == 0 or count < 1:
        return count
    if first + count - 1 > MAX_SEED_VALUE:
        raise click.BadParameter(f"the last seed {first + count - 1} is over {MAX_SEED_VALUE}",
                                 param_hint="--first-seed")
    return list(range(first, first + count))


@click.command()
@click.option("--system", type=click.Choice(list(PRESETS)),
              help="Preset to start from (default: the base of a saved system's --params-file).")
@click.option("--algorithms", help="Comma-separated labels, e.g. uniform,mgrao-1:1,mgrao-5:1,mgrao-max "
              "(default: the paper's for the system).")
@click.option("--seeds", default=30, show_default=True, type=int, help="Number of seeds (F .. F+S-1).")
@click.option("--first-seed", default=0, show_default=True, type=click.IntRange(0, MAX_SEED_VALUE),
              help="The first seed F (e.g. 10000 for the calibration seeds).")
@click.option("--episodes", default=100, show_default=True, type=int, help="Episodes per run.")
@click.option("--set", "sets", multiple=True, metavar="NAME=VALUE",
              help="Override a parameter (repeatable); a list or event list as JSON: --set schedule='[...]'.")
@click.option("--params-file", metavar="FILE",
              help="Parameter values from a JSON file: an object of them, or a saved system's file (mgrao "
              "systems export); --set applies on top.")
@click.option("--format", "fmt", default="table", show_default=True, type=click.Choice(["table", "json", "csv"]))
@click.option("--until", "until_text", metavar="KEY=VALUE,...",
              help="Run seeds in blocks from --first-seed until a question is answered (instead of --seeds): "
              "half_width=H (the 95% interval of every configuration judged within +-H), judge=A+B (which; "
              "default: every one but uniform and the oracle), joint=true (all judged intervals at once: each at "
              "1 - 0.05/k), decide=A+B (the paired difference decided; half_width then the margin of no practical "
              "difference), of=pct_from_uniform|final_utility, max_seeds=500, block=10 (docs/statistics.md).")
@click.option("--out", type=click.Path(dir_okay=False, writable=True), callback=_check_out,
              help="Write to FILE instead of stdout.")
@click.pass_context
def run(ctx: click.Context, system: str | None, algorithms: str | None, seeds: int, first_seed: int, episodes: int,
        sets: tuple[str, ...], params_file: str | None, fmt: str, until_text: str | None, out: str | None) -> None:
    """Simulate one system with several algorithms and seeds; print the summary or every episode."""
    labels = _algorithm_labels(algorithms)
    base, overrides = read_params_file(params_file) if params_file else (None, {})
    system = system or base
    if system is None:
        raise click.UsageError("give --system, or a saved system's file as --params-file")
    if until_text is not None and ctx.get_parameter_source("seeds") != click.core.ParameterSource.DEFAULT:
        raise click.UsageError("give either --seeds or --until: a rule runs as many seeds as its question needs "
                               "(its max_seeds bounds them)")
    until = None
    try:
        if until_text is None:
            spec = make_spec(system, labels, _seed_range(seeds, first_seed), episodes, overrides | _parse_sets(sets))
        else:
            spec, until = until_spec(system, labels, first_seed, episodes, overrides | _parse_sets(sets),
                                     parse_until(until_text))
    except ConfigError as error:
        _fail(error)
    load_engine()
    started = time.perf_counter()
    bar = spec.work >= PROGRESS_BAR_WORK
    with _progress(f"{system}", bar) as update:
        said = _compile_notices(bar)
        if until is None:
            result, done = mgrao_core.run_experiment(spec, on_progress=update, on_compile=said), None
        else:
            done = run_until(spec, until, functools.partial(mgrao_core.run_experiment, on_compile=said),
                             on_block=lambda _result, verdict: update(verdict.seeds / until.max_seeds))
            result, spec = done.result, done.result.spec
    elapsed = time.perf_counter() - started
    summary, tasks = result.summary(), result.task_counts()
    if fmt == "json":
        payload = {
            "spec": spec.as_dict(),
            "simulation_seconds": elapsed,
            **({} if done is None else {"until": until.as_dict(),
                                        "stopped": done.stopped.as_dict() | coverage_of(until.as_dict()),
                                        "blocks": [verdict.as_dict() for verdict in done.blocks]}),
            "summary": {label: {**s.as_dict(), **tasks[label].rates()} for label, s in summary.items()},
            "runs": [
                {"algorithm": r.algorithm, "seed": r.seed, "utilities": r.utilities.tolist(),
                 "combined_weights": r.combined_weights.tolist(), **r.tasks.rates()}
                for r in result.runs
            ],
        }
        _emit(json.dumps(payload, indent=2), out)
    elif fmt == "csv":
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(["algorithm", "seed", "episode", "utility"])
        for r in result.runs:
            writer.writerows((r.algorithm, r.seed, e, repr(float(u))) for e, u in enumerate(r.utilities))
        _emit(buffer.getvalue(), out)
        if done is not None:  # the rows are every episode; why they stop where they do goes beside them
            click.echo(_stopped_line(done.stopped), err=True)
    else:
        rows = [
            [s.algorithm, _fmt(s.final_mean, 3), _interval(s.ci95, 3), _fmt(s.pct_from_uniform),
             _interval(s.pct_ci95), _fmt(s.pct_of_max)]
            for s in summary.values()
        ]
        headers = ["algorithm", "final mean", "95% CI", "% from uniform", "95% CI", "% of max"]
        if spec.params.tasks_can_fail:  # what became of the tasks
            rows = [[*row, _fmt(100 * tasks[row[0]].failure_rate), _fmt(100 * tasks[row[0]].handover_rate)]
                    for row in rows]
            headers += ["% failed", "% by a neighbour"]
        title = (f"{system}: {len(spec.seeds)} seeds x {spec.episodes} episodes, "
                 f"mean of the last 10 episodes ({elapsed:.2f} s)")
        stopped = "" if done is None else f"\n{_stopped_line(done.stopped)}"
        _emit(f"{title}\n{text_table(headers, rows)}{stopped}", out)


def _stopped_line(verdict: Verdict) -> str:
    """Why a rule stopped, and the interval of a decided pair."""
    judged = ", ".join(k for k in verdict.intervals if " - " not in k)
    line = f"stopped: {verdict.reason} after {verdict.seeds} seeds" + (
        f" (judged: {judged}; each interval at {100 * verdict.level:g}%)" if judged else "")
    if verdict.outcome is not None or len(verdict.intervals) == 1 and " - " in next(iter(verdict.intervals)):
        (key, (mean, low, high)), = verdict.intervals.items()
        line += f"; {key}: {_fmt(mean, 2)} {_interval((low, high), 2)}" + (
            f" ({verdict.outcome})" if verdict.outcome else "")
    return line


@click.command()
@click.option("--seeds", default=DEFAULT_SEEDS, show_default=True, type=int, help="Seeds per configuration.")
@click.option("--first-seed", default=0, show_default=True, type=click.IntRange(0, MAX_SEED_VALUE),
              help="The first seed (0 .. 99 are the held-out seeds; the calibration uses 10000 on).")
@click.option("--episodes", default=100, show_default=True, type=int, help="Episodes per run (paper: 100).")
@click.option("--reading", type=click.Choice(list(READINGS)), default="default", show_default=True,
              help="A named environment reading (docs/reproduction.md); --set applies on top.")
@click.option("--set", "sets", multiple=True, metavar="NAME=VALUE",
              help="Override a parameter in every system, e.g. temperature=1 (repeatable).")
@click.option("--format", "fmt", default="table", show_default=True, type=click.Choice(["table", "json"]))
@click.option("--out", type=click.Path(dir_okay=False, writable=True), callback=_check_out,
              help="Write to FILE instead of stdout.")
def reproduce(seeds: int, first_seed: int, episodes: int, reading: str, sets: tuple[str, ...], fmt: str,
              out: str | None) -> None:
    """Run the paper's four systems and print its tables with ours beside them."""
    overrides = READINGS[reading] | _parse_sets(sets)
    load_engine()
    started = time.perf_counter()
    try:
        with _progress("reproduce", seeds * episodes >= 30_000) as update:
            count = len(PAPER_SYSTEMS)
            order = {name: i for i, name in enumerate(PAPER_SYSTEMS)}
            results = run_reproduction(
                _seed_range(seeds, first_seed), episodes, overrides,
                on_progress=lambda name, f: update((order[name] + f) / count),
                on_compile=_compile_notices(seeds * episodes >= 30_000),
            )
    except ConfigError as error:
        _fail(error)
    elapsed = time.perf_counter() - started
    table = reproduction_table(results)
    table.update({"seeds": seeds, "first_seed": first_seed, "episodes": episodes, "reading": reading,
                  "overrides": overrides, "simulation_seconds": elapsed})
    if fmt == "json":
        _emit(json.dumps(table, indent=2), out)
        return
    blocks = []
    for name, rows in table["systems"].items():
        judged = {label: deciding_digits(r["ci95"], r["paper_pct_from_uniform"]) for label, r in rows.items()}
        body = [  # an interval and the paper's figure to the decimal that shows the verdict (the paper view's rule)
            [label, _fmt(r["pct_from_uniform"]), _interval(r["ci95"], judged[label]),
             _fmt(r["paper_pct_from_uniform"], judged[label]) + (" *" if r["paper_outside_ci"] else "  "),
             _fmt(r["pct_of_max"]), _fmt(r["paper_pct_of_max"])]
            for label, r in rows.items() if label != "uniform"
        ]
        headers = ["algorithm", "% from uniform", "95% CI", "paper", "% of max", "paper"]
        overtakes = table["max_overtakes_1_1_at"][name]
        when = "never" if overtakes is None else f"from episode {overtakes}"
        blocks.append(f"{name} ({PRESETS[name].description})\n{text_table(headers, body)}\n"
                      f"mgrao-max stays ahead of mgrao-1:1 {when} (paper: by about episode 10)")
    footer = (f"{seeds} seeds x {episodes} episodes per configuration, reading {reading}"
              + (f" with {', '.join(f'{k}={v}' for k, v in _parse_sets(sets).items())}" if sets else "")
              + f"; mean of the last 10 episodes; * the paper's figure lies outside our 95% interval; "
              f"simulation {elapsed:.2f} s")
    _emit("\n\n".join(blocks) + f"\n\n{footer}", out)
