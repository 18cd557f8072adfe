"""The ``mgrao`` command line: run experiments, reproduce the paper, serve the dashboard.

Each subcommand's module is imported when that subcommand runs (or ``--help`` lists it), so that
``mgrao reproduce`` does not import the service's and the studies' modules (sockets, HTTP).
"""

from __future__ import annotations

import importlib

import click

COMMANDS = {
    "algorithms": "mgrao_cli.algorithms:algorithms",
    "compare": "mgrao_cli.compare:compare",
    "compile": "mgrao_cli.compiling:compile_engine",
    "run": "mgrao_cli.experiments:run",
    "reproduce": "mgrao_cli.experiments:reproduce",
    "serve": "mgrao_cli.service_commands:serve",
    "worker": "mgrao_cli.service_commands:worker",
    "dispatcher": "mgrao_cli.service_commands:dispatcher",
    "migrate": "mgrao_cli.service_commands:migrate",
    "study": "mgrao_cli.studies:study",
    "systems": "mgrao_cli.systems:systems",
    "log": "mgrao_cli.logging_command:log",
}
"""Subcommand name to ``module:attribute`` of its click command."""


class LazyGroup(click.Group):
    """A click group whose subcommands are imported on first use, from :data:`COMMANDS`."""

    def list_commands(self, ctx: click.Context) -> list[str]:
        """Every subcommand's name, sorted (as click lists them)."""
        return sorted(set(super().list_commands(ctx)) | set(COMMANDS))

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        """The subcommand ``cmd_name``, its module imported now; None if there is none."""
        if cmd_name not in self.commands and cmd_name in COMMANDS:
            module, _, attribute = COMMANDS[cmd_name].partition(":")
            self.add_command(getattr(importlib.import_module(module), attribute), cmd_name)
        return super().get_command(ctx, cmd_name)


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="mgrao")
def cli() -> None:
    """MG-RAO experiments from the shell: simulate, reproduce the paper, serve the dashboard, log runs from outside."""


if __name__ == "__main__":
    cli()
