"""Entry point of the ``chronofuse`` program. Each subcommand lives in its own module.

Start-up is lazy: the program imports only the module of the subcommand it runs (``chronofuse detect ...``
loads ``cli/detect.py`` and what it needs, not the whole toolkit), so ``chronofuse detect --help`` answers in
a fraction of a second; a command line without a subcommand (``chronofuse --help``) loads none of them
(:data:`SUMMARIES`). ``app`` (the full program with every subcommand, for ``CliRunner`` in tests and for
``chronofuse --help``) is built on first access.

Exit status: 0 done (and, where a command gives a verdict, its own codes: ``detect`` 1 alarm, 3 integrity
unavailable); 2 bad input, one line naming the option, file or line (:mod:`chronofuse.cli.common`); 70 a bug
of chronofuse (any other error), one line saying so, the traceback with ``chronofuse --debug ...`` or
``CHRONOFUSE_DEBUG=1``.
"""

from __future__ import annotations

import importlib
import os
import sys
import traceback

import typer
from typer.core import TyperGroup
from typer._click.exceptions import ClickException  # typer's click; the version is pinned
from typer._coercion import PassThroughRuntimeParam  # see _Program.parse_args
from typer.exceptions import Abort, Exit, TyperException

from chronofuse import __version__
from chronofuse.cli.loading import loading, process_ends_with_command

#: Subcommand -> the cli modules that register it. ``reproduce`` gathers experiments from several modules.
COMMANDS: dict[str, tuple[str, ...]] = {
    "simulate": ("simulate",),
    "stability": ("stability",),
    "run": ("run",),
    "detect": ("detect",),
    "gnssdo": ("gnssdo",),
    "characterize": ("characterize",),
    "position": ("position",),
    "swarm": ("swarm",),
    "inspect": ("inspect",),
    "monitor": ("monitor",),
    "log": ("log",),
    "validate": ("validate",),
    "reproduce": ("reproduce", "gnssdo", "position", "swarm"),
}


#: What ``chronofuse --help`` lists, in its order, each command's help as the command gives it: the program
#: lists them from here without importing any subcommand's module (each imports the library it needs, which
#: takes seconds for some). tests/cli/test_lazy_help.py renders the full program's help and this one's and
#: compares them, so a changed docstring shows up there.
SUMMARIES: dict[str, str] = {
    "stability": "ADEV, OADEV, MDEV, TDEV, HDEV, OHDEV, total deviations, Theo1, TheoBR, TheoH, TIE rms and MTIE, "
                 "with confidence intervals.",
    "run": "Simulate a scenario and write its report (JSON, CSV, PNG): the free-running OCXO and the receivers, the\n"
           "OCXO disciplined to them through a GNSS outage, and followers keeping its time over two-way links.",
    "detect": "Detect clock-bias anomalies with the high-order-difference chi-square test.",
    "gnssdo": "GNSS-disciplined oscillator (the GNSSDO paper): time error, convergence, holdover, states and ADEV.",
    "characterize": "Fit an oscillator's h-coefficients, drift and temperature coefficient to its record; loop and "
                    "holdover.",
    "position": "Single-point fixes from a RINEX file (--obs), or a simulated drive comparing GNSS-only, GNSS/INS and\n"
                "(with --smooth) RTS-smoothed positions.",
    "inspect": "Receivers, message counts per type, time span, gaps, checksum failures, unknown talkers.",
    "monitor": "Live table per receiver (fix, satellites, GDOP, usable and why not, UTC, leap, clock bias/drift, qErr,\n"
               "alarms, age), events on stderr, the log, a web dashboard, metrics, alert hooks and a chrony feed.",
    "validate": "Our statistics on real records against Stable32's tables, the receiver model against the GPS\n"
                "record, each oscillator preset against theory: one PASS/FAIL line per check (exit 1 if any fails).",
    "simulate": "Simulate clocks and receivers (truth models) and write them to a file.",
    "swarm": "Swarm clock synchronization over two-way radio links.",
    "log": "Query a monitor log: epochs, availability, outages, alarms, dissent; export CSV/Parquet.",
    "reproduce": "Reproduce the source papers' experiments and write their reports.",
}

#: Exit status of a bug (sysexits' EX_SOFTWARE): apart from bad input (2) and a command's verdicts (0, 1, 3).
EXIT_BUG = 70


def usage_error_line(exc) -> str:
    """A usage error (unknown option, bad value, missing argument) as one line naming the command and the
    option: ``chronofuse detect: error: No such option: --foo (Possible options: --follow, --pfa)``."""
    ctx = getattr(exc, "ctx", None)
    where = ctx.command_path if ctx is not None else "chronofuse"
    message = " ".join(part.strip() for part in exc.format_message().splitlines() if part.strip())
    return f"{where}: error: {message}"


class _Program(TyperGroup):
    """The root command: an error that is not the user's (not one :mod:`chronofuse.cli.common` turned into
    exit 2, not a usage error) is a bug, said so in one line on stderr, exit :data:`EXIT_BUG`; with
    ``--debug`` (or ``CHRONOFUSE_DEBUG=1``) the traceback follows. A usage error is one line on stderr
    (:func:`usage_error_line`), exit 2, on every subcommand (not click's usage text and a framed box)."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode: bool = True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except ClickException as exc:
            if type(exc).__name__ != "NoArgsIsHelpError":  # that one has printed the help already
                sys.stderr.write(usage_error_line(exc) + "\n")
                sys.stderr.flush()
            sys.exit(exc.exit_code)
        except Abort:
            sys.stderr.write("Aborted!\n")
            sys.exit(1)
        sys.exit(code if isinstance(code, int) else 0)

    def parse_args(self, ctx, args):
        # The root's own options are bool flags (--help, --version, --debug and the completion pair). Typer
        # coerces a flag left out (None) through a pydantic TypeAdapter it builds on first use, which imports
        # pydantic (about 1 s of ``chronofuse detect --help`` on a loaded machine, half its time) to turn None
        # into None. A flag's value is a bool or None: no coercion to build.
        for param in self.get_params(ctx):  # with the help option click adds
            if getattr(param, "_runtime_param", False) is None and param.type_descriptor.annotation is bool:
                param._runtime_param = PassThroughRuntimeParam(parameter_info=param.type_descriptor.parameter_info,
                                                               annotation=bool)
        return super().parse_args(ctx, args)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except (Exit, Abort, TyperException, KeyboardInterrupt):
            raise
        except Exception as exc:
            debug = bool(ctx.params.get("debug")) or os.environ.get("CHRONOFUSE_DEBUG", "") not in ("", "0")
            first = (str(exc).splitlines() or [""])[0]
            hint = "" if debug else "; run it again with chronofuse --debug ... for the traceback"
            sys.stderr.write(f"error: a bug in chronofuse, not in your input ({type(exc).__name__}: {first}){hint}\n")
            if debug:
                traceback.print_exception(exc, file=sys.stderr)
            sys.stderr.flush()
            raise Exit(EXIT_BUG) from None


def _root() -> typer.Typer:
    program = typer.Typer(
        name="chronofuse",
        cls=_Program,
        help="Precision timing: simulate clocks and GNSS receivers, analyse stability, watch clock integrity, "
             "discipline oscillators, synchronize swarms, position with GNSS/INS.",
        no_args_is_help=True,
        add_completion=True,
        pretty_exceptions_enable=False,
    )

    @program.callback(invoke_without_command=True)
    def _main(version: bool = typer.Option(False, "--version", help="Print the version and exit."),
              debug: bool = typer.Option(False, "--debug", help="On a bug (exit 70), print the traceback.")) -> None:
        if version:
            typer.echo(__version__)
            raise typer.Exit()

    return program


def build_app(modules: tuple[str, ...] | None = None) -> typer.Typer:
    """The Typer program with the subcommands of ``modules`` (all when None)."""
    program = _root()
    wanted = modules or tuple(dict.fromkeys(m for group in COMMANDS.values() for m in group))
    for name in wanted:
        importlib.import_module(f"chronofuse.cli.{name}").register(program)
    return program


def build_index() -> typer.Typer:
    """The program as a command line without a subcommand sees it (``chronofuse --help``, ``--version``, an
    unknown command): every subcommand listed with its :data:`SUMMARIES` entry, none of their modules loaded."""
    program = _root()
    for name, summary in SUMMARIES.items():
        program.command(name, help=summary, add_help_option=False,
                        context_settings={"ignore_unknown_options": True, "allow_extra_args": True})(_listed_only)
    return program


def _listed_only() -> None:  # pragma: no cover - a command line naming a subcommand builds the real one
    raise RuntimeError("the index of subcommands was asked to run one")


def _wanted(argv: list[str]) -> tuple[str, ...] | None:
    """The modules a command line needs: its first word's, or all (no subcommand, or one we do not know)."""
    first = next((a for a in argv if not a.startswith("-")), None)
    return COMMANDS.get(first) if first is not None else None


def _completing() -> list[str]:
    """The words after ``chronofuse`` of a command line the shell asks to complete (Typer's completion:
    ``COMP_WORDS`` from bash, ``_TYPER_COMPLETE_ARGS`` from zsh, fish and PowerShell), so that a subcommand
    being completed is built with its options (a first word that is no subcommand yet builds the index);
    [] when no completion is asked for."""
    if not os.environ.get("_CHRONOFUSE_COMPLETE"):
        return []
    return (os.environ.get("COMP_WORDS") or os.environ.get("_TYPER_COMPLETE_ARGS") or "").split()[1:]


def main() -> None:
    """The console script: build only what this command line runs, then run it.

    Collection is paused while the program and its subcommand load (:func:`~chronofuse.cli.loading.loading`).
    The heap is not frozen on the way out: freezing it there (so that the interpreter's last collections
    skip what the run built) left objects unfinalized at exit, and ncompress (nanobind, loaded by the RINEX
    readers) then printed "leaked 1 functions" on every RINEX command; it saved no measurable time once
    the modules loaded under :func:`~chronofuse.cli.loading.loading` are frozen.
    """
    process_ends_with_command()
    with loading():
        wanted = _wanted(_completing() or sys.argv[1:])
        program = build_app(wanted) if wanted is not None else build_index()
    program(prog_name="chronofuse")


def __getattr__(name: str):
    if name == "app":
        full = build_app()
        globals()["app"] = full
        return full
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


if __name__ == "__main__":  # pragma: no cover
    main()
