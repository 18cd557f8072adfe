"""``mgrao systems``: a running service's saved systems (a base preset plus overrides, used like a preset).

``save NAME --from single --set n_parents=12 --set schedule='[...]'`` (or ``--file FILE.json``, a saved
system's file or an object of parameter values), ``list``, ``export NAME`` (the file) and ``delete NAME``.
"""

from __future__ import annotations

import json
from typing import Any

import click

from mgrao_cli.experiments import _parse_sets, read_params_file
from mgrao_cli.studies import TOKEN_OPTION, URL_OPTION, Api
from mgrao_core.presets import PRESETS


@click.group()
def systems() -> None:
    """Saved systems of a running service: save, list, export, delete."""


@systems.command()
@click.argument("name")
@click.option("--from", "base", type=click.Choice(list(PRESETS)),
              help="The base preset (default: a saved system file's base, else single).")
@click.option("--set", "sets", multiple=True, metavar="NAME=VALUE",
              help="A parameter value (repeatable); a list or event list as JSON.")
@click.option("--file", "path", metavar="FILE", help="A saved system's file, or an object of parameter values; "
              "--set applies on top.")
@click.option("--description", default=None, help="One line for the dashboard's system picker.")
@click.option("--replace", is_flag=True, help="Replace a saved system of that name.")
@URL_OPTION
@TOKEN_OPTION
def save(name: str, base: str | None, sets: tuple[str, ...], path: str | None, description: str | None,
         replace: bool, url: str, token: str | None) -> None:
    """Save NAME: a base preset and parameter values (validated by the service on the preset)."""
    file_base, params, file_description = None, {}, ""
    if path:
        file_base, params = read_params_file(path)
        with open(path, encoding="utf-8") as handle:
            file_description = str(json.load(handle).get("description", "")) if file_base else ""
    body: dict[str, Any] = {"name": name, "description": description if description is not None else file_description,
                            "base": base or file_base or "single", "params": params | _parse_sets(sets)}
    api = Api(url, token)
    saved = api.call("PUT", f"/api/systems/saved/{name}", body) if replace else api.call(
        "POST", "/api/systems/saved", body)
    click.echo(f"saved {saved['name']}: {saved['base']} with {_overrides(saved['params'])}")


@systems.command(name="list")
@URL_OPTION
@TOKEN_OPTION
def list_systems(url: str, token: str | None) -> None:
    """The saved systems: name, base, overrides and description."""
    for saved in Api(url, token).call("GET", "/api/systems/saved"):
        click.echo(f"{saved['name']}\t{saved['base']}\t{_overrides(saved['params'])}\t{saved['description']}")


@systems.command()
@click.argument("name")
@click.option("--out", type=click.Path(dir_okay=False, writable=True), help="Write to FILE instead of stdout.")
@URL_OPTION
@TOKEN_OPTION
def export(name: str, out: str | None, url: str, token: str | None) -> None:
    """NAME's file (name, description, base, params), as `systems save --file` and `run --params-file` take it."""
    saved = Api(url, token).call("GET", f"/api/systems/saved/{name}")
    text = json.dumps({k: saved[k] for k in ("name", "description", "base", "params")}, indent=2) + "\n"
    if out:
        with open(out, "w", encoding="utf-8") as handle:
            handle.write(text)
    else:
        click.echo(text, nl=False)


@systems.command()
@click.argument("name")
@URL_OPTION
@TOKEN_OPTION
def delete(name: str, url: str, token: str | None) -> None:
    """Forget NAME (its jobs keep their configuration)."""
    Api(url, token).call("DELETE", f"/api/systems/saved/{name}")
    click.echo(f"deleted {name}")


def _overrides(params: dict[str, Any]) -> str:
    return ", ".join(f"{k}={json.dumps(v)}" for k, v in params.items()) or "no overrides"
