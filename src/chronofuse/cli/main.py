"""Entry point of the ``chronofuse`` program. Each subcommand lives in its own module.

Start-up is lazy: the program imports only the module of the subcommand it runs (``chronofuse detect ...``
loads ``cli/detect.py`` and what it needs, not the whole toolkit), so ``chronofuse detect --help`` answers in
a fraction of a second. ``app`` (the full program with every subcommand, for ``CliRunner`` in tests and for
``chronofuse --help``) is built on first access.
"""

from __future__ import annotations

import gc
import importlib
import sys

import typer

from chronofuse import __version__
from chronofuse.cli.loading import loading, process_ends_with_command

#: Subcommand -> the cli modules that register it. ``reproduce`` gathers experiments from several modules.
COMMANDS: dict[str, tuple[str, ...]] = {
    "simulate": ("simulate",),
    "stability": ("stability",),
    "run": ("run",),
    "detect": ("detect",),
    "gnssdo": ("gnssdo",),
    "position": ("position",),
    "swarm": ("swarm",),
    "inspect": ("inspect",),
    "monitor": ("monitor",),
    "log": ("log",),
    "validate": ("validate",),
    "reproduce": ("reproduce", "gnssdo", "position", "swarm"),
}


def build_app(modules: tuple[str, ...] | None = None) -> typer.Typer:
    """The Typer program with the subcommands of ``modules`` (all when None)."""
    program = typer.Typer(
        name="chronofuse",
        help="Precision timing: simulate clocks and GNSS receivers, analyse stability, watch clock integrity, "
             "discipline oscillators, synchronize swarms, position with GNSS/INS.",
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
    )
    wanted = modules or tuple(dict.fromkeys(m for group in COMMANDS.values() for m in group))
    for name in wanted:
        importlib.import_module(f"chronofuse.cli.{name}").register(program)

    @program.callback(invoke_without_command=True)
    def _main(version: bool = typer.Option(False, "--version", help="Print the version and exit.")) -> None:
        if version:
            typer.echo(__version__)
            raise typer.Exit()

    return program


def _wanted(argv: list[str]) -> tuple[str, ...] | None:
    """The modules a command line needs: its first word's, or all (no subcommand, or one we do not know)."""
    first = next((a for a in argv if not a.startswith("-")), None)
    return COMMANDS.get(first) if first is not None else None


def main() -> None:
    """The console script: build only what this command line runs, then run it.

    Collection is paused while the program and its subcommand load (:func:`~chronofuse.cli.loading.loading`).
    On the way out the heap is frozen (:func:`gc.freeze`): the interpreter's last collections then skip
    everything the run built, which with numba loaded is most of the exit's time (0.3-0.45 s of a 2 s
    ``stability`` run). ``atexit`` handlers still run and every file the commands write is closed by its
    ``with`` block before this point; only cyclic garbage left at exit is not collected.
    """
    process_ends_with_command()
    try:
        with loading():
            program = build_app(_wanted(sys.argv[1:]))
        program()
    finally:
        gc.freeze()


def __getattr__(name: str):
    if name == "app":
        full = build_app()
        globals()["app"] = full
        return full
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if __name__ == "__main__":  # pragma: no cover
    main()
