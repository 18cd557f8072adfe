"""The ``mgrao`` command line: run experiments, reproduce the paper, serve the dashboard."""

from __future__ import annotations

import click

from mgrao_cli.experiments import reproduce, run
from mgrao_cli.service_commands import dispatcher, migrate, serve, worker
from mgrao_cli.studies import study


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="mgrao")
def cli() -> None:
    """MG-RAO experiments from the shell: simulate, reproduce the paper, serve the dashboard."""


cli.add_command(run)
cli.add_command(reproduce)
cli.add_command(serve)
cli.add_command(worker)
cli.add_command(dispatcher)
cli.add_command(migrate)
cli.add_command(study)


if __name__ == "__main__":
    cli()
