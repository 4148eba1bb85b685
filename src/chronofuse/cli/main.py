"""Entry point of the ``chronofuse`` program. Each subcommand lives in its own module."""

from __future__ import annotations

import typer

from chronofuse import __version__
from chronofuse.cli import detect, reproduce, run, simulate, stability, swarm, validate

app = typer.Typer(
    name="chronofuse",
    help="Precision timing: simulate clocks and GNSS receivers, analyse stability, watch clock integrity.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

for module in (simulate, stability, run, detect, reproduce, validate, swarm):
    module.register(app)


@app.callback(invoke_without_command=True)
def _main(version: bool = typer.Option(False, "--version", help="Print the version and exit.")) -> None:
    if version:
        typer.echo(__version__)
        raise typer.Exit()


if __name__ == "__main__":  # pragma: no cover
    app()
