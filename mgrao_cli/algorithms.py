"""``mgrao algorithms``: the algorithm registry, as ``GET /api/algorithms`` serves it."""

from __future__ import annotations

import json
from typing import Any

import click

from mgrao_core import ConfigError
from mgrao_core.algorithms import describe_label, registry
from mgrao_core.presets import PRESETS, get_preset


def _memory(count: int | None) -> str:
    if count is None:
        return "-"
    return f"{count:,} B" if count < 10 * 1024 else f"{count / 1024:,.1f} KiB"


def _describe_family(entry: dict[str, Any]) -> list[str]:
    lines = [f"{entry['name']} ({entry['title']}): {entry['description']}"]
    if entry["parameters"]:
        lines.append(f"  parameters: {', '.join(entry['parameters'])}")
    for form in entry["forms"]:
        shown = "; ".join(f"{name} in {', '.join(str(v) for v in values)}" for name, values in (
            (form["argument"], form.get("valid")), (form.get("second_argument"), form.get("second_valid"))) if values)
        lines.append(f"  {form['template']}: {form['description']}{f' ({shown})' if shown else ''}")
    memory = entry["memory_per_child"] or {}
    lines.append("  examples: " + ", ".join(
        f"{label} ({_memory(memory[label])} per child)" if label in memory else label for label in entry["examples"]))
    return lines


@click.command("algorithms")
@click.option("--system", type=click.Choice(sorted(PRESETS)), default=None,
              help="Describe for this system: the labels valid in it and the memory per child.")
@click.option("--label", default=None, help="Canonicalise and describe one label.")
@click.option("--json", "as_json", is_flag=True, help="Print JSON, as the API's GET /api/algorithms answers.")
def algorithms(system: str | None, label: str | None, as_json: bool) -> None:
    """List the algorithm families (label forms, examples, memory per child), or describe one label."""
    params = None if system is None else get_preset(system).params
    if label is not None:
        try:
            described = describe_label(label, params)
        except ConfigError as error:
            raise click.BadParameter(error.message, param_hint="--label") from None
        if as_json:
            click.echo(json.dumps(described, indent=2))
        else:
            click.echo(f"{described['label']}: {described['title']} ({described['family']})")
            click.echo(f"  {described['description']}")
            if described["groups"] is not None:
                click.echo(f"  parent groups per child: {described['groups']}")
            if (described.get("team_size") or 1) > 1:
                click.echo(f"  children sharing one model: {described['team_size']}")
            click.echo(f"  memory per child: {_memory(described['memory_per_child'])}")
        return
    entries = registry(params)
    if as_json:
        click.echo(json.dumps({"data": entries}, indent=2))
        return
    click.echo("\n\n".join("\n".join(_describe_family(entry)) for entry in entries))
