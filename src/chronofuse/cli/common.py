"""What every subcommand shares: JSON output, one-line errors with exit code 2, the console."""

from __future__ import annotations

import sys
import warnings
from contextlib import contextmanager

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from chronofuse.report.jsonio import dumps
from chronofuse.validation import ChronofuseError

# Human output goes to stderr when --json owns stdout; otherwise to stdout.
console = Console(highlight=False)
err_console = Console(stderr=True, highlight=False)

EXIT_BAD_INPUT = 2


def print_json(doc: dict) -> None:
    """Print one JSON document on stdout (NaN/inf become null) and nothing else."""
    sys.stdout.write(dumps(doc) + "\n")
    sys.stdout.flush()


def fail(message: str) -> None:
    """Print a one-line error on stderr and exit with code 2."""
    err_console.print(f"error: {message}", markup=False, soft_wrap=True)
    raise typer.Exit(EXIT_BAD_INPUT)


@contextmanager
def user_errors():
    """Turn the library's input errors (and ValueError from validation) into one-line errors, exit 2."""
    try:
        yield
    except (ChronofuseError, ValueError, FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        fail(text)


def human_console(json_mode: bool) -> Console:
    """The console for human-readable output: stderr when stdout carries JSON."""
    return err_console if json_mode else console


@contextmanager
def progress_reporter(label: str):
    """A rich progress display on stderr for work that takes more than a second.

    Yields ``say(message)``, which moves the display to the next stage; the display is transient and
    never touches stdout, so ``--json`` output stays clean.
    """
    columns = (SpinnerColumn(), TextColumn("[bold]{task.description}"), BarColumn(), TimeElapsedColumn())
    # Off when stderr is not a terminal: a non-terminal progress display leaves a blank line behind.
    with Progress(*columns, console=err_console, transient=True, disable=not err_console.is_terminal) as bar:
        task = bar.add_task(label, total=None)

        def say(message: str) -> None:
            bar.update(task, description=f"{label}: {message}")

        yield say


def run_reproduction(label: str, reproduce, out, *, quick: bool, json_out: bool) -> dict | None:
    """Run a ``chronofuse reproduce`` experiment, ``reproduce(out, quick=quick, progress=say)``, with one-line
    errors and a progress display; with ``json_out`` print ``{"out": ..., **summary}`` and return None, else
    return the summary for the human tables."""
    with user_errors():
        with progress_reporter(label) as say:
            summary = reproduce(out, quick=quick, progress=say)
    if json_out:
        print_json({"out": str(out), **summary})
        return None
    return summary


@contextmanager
def collected_warnings():
    """Collect the library's warnings (e.g. taus dropped beyond a statistic's range) into a list of
    one-line messages, instead of Python's two-line warning output; the command reports them."""
    messages: list[str] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield messages
    messages.extend(str(w.message).splitlines()[0] for w in caught)
