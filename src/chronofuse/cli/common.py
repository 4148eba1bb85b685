"""What every subcommand shares: JSON output, one-line errors with exit code 2, the console."""

from __future__ import annotations

import json
import math
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from chronofuse.validation import ChronofuseError

# Human output goes to stderr when --json owns stdout; otherwise to stdout.
console = Console(highlight=False)
err_console = Console(stderr=True, highlight=False)

EXIT_BAD_INPUT = 2


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, np.bool_):
        return bool(obj)
    if isinstance(obj, Path):
        return str(obj)
    return obj


def print_json(doc: dict) -> None:
    """Print one JSON document on stdout (NaN/inf become null) and nothing else."""
    sys.stdout.write(json.dumps(_jsonable(doc), indent=2) + "\n")
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
