"""``python -m mgrao_cli``: the same as the ``mgrao`` command."""

from mgrao_cli.main import cli

cli()
