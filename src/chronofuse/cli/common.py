"""What every subcommand shares: JSON output, one-line errors with exit code 2, the console.

Exit status 2 means bad input, and only the library's own errors (:class:`~chronofuse.validation.ChronofuseError`:
a bad value, file, model file or address), the operating system's refusal of a path the user named, and a
config's validation error say so; their fields are written as the options that set them
(:func:`chronofuse.cli.flags.label`). Anything else is a bug, reported as one by the program
(:mod:`chronofuse.cli.main`).
"""

from __future__ import annotations

import os
import sys
import time
import warnings
from contextlib import contextmanager

import typer
from rich.console import Console
from rich.progress import (BarColumn, Progress, SpinnerColumn, TaskProgressColumn, TextColumn, TimeElapsedColumn,
                           TimeRemainingColumn)

from chronofuse.cli.flags import FLAG_OF_FIELD, label
from chronofuse.report.jsonio import dumps
from chronofuse.validation import ChronofuseError, InputError, InputWarning

# Human output goes to stderr when --json owns stdout; otherwise to stdout. Errors have their own console, which
# --quiet leaves alone.
console = Console(highlight=False)
err_console = Console(stderr=True, highlight=False)
_errors = Console(stderr=True, highlight=False)

EXIT_BAD_INPUT = 2


def print_json(doc: dict) -> None:
    """Print one JSON document on stdout (NaN/inf become null) and nothing else."""
    sys.stdout.write(dumps(doc) + "\n")
    sys.stdout.flush()


def quiet_output(enabled: bool) -> None:
    """``--quiet``: tables, notes, warnings and progress displays print nothing; errors, the ``--json``
    document and ``--json-lines`` still do (every command calls this first, with its option's value)."""
    console.quiet = err_console.quiet = bool(enabled)


def fail(message: str) -> None:
    """Print a one-line error on stderr and exit with code 2."""
    _errors.print(f"error: {message}", markup=False, emoji=False, soft_wrap=True)  # "1:a:b" is not ":a:" (an emoji)
    raise typer.Exit(EXIT_BAD_INPUT)


def _offered() -> set[str] | None:
    """The options of the command running now (None outside a command)."""
    from typer._click.globals import get_current_context  # typer's click; the version is pinned

    ctx = get_current_context(silent=True)
    return None if ctx is None else {name for p in ctx.command.params for name in getattr(p, "opts", ())}


def _label(field: str) -> str:
    """A config field written as the running command's option that sets it; the field itself where this
    command has no such option (a field of the same name set by another command's option is not this one's)."""
    offered = _offered()
    if offered is not None and FLAG_OF_FIELD.get(field) not in offered:
        return field
    return label(field)


def describe(exc: BaseException) -> str | None:
    """The one-line message of a user's error, options named as on the command line; None for a bug."""
    if isinstance(exc, InputError):
        return exc.render(_label).splitlines()[0]
    if isinstance(exc, ChronofuseError):
        return (str(exc) or type(exc).__name__).splitlines()[0]
    if isinstance(exc, OSError) and exc.filename is not None:
        return f"{exc.filename}: {exc.strerror or type(exc).__name__}"
    if type(exc).__name__ == "ValidationError" and type(exc).__module__.startswith("pydantic"):
        first = exc.errors()[0]
        where = ".".join(str(part) for part in first.get("loc", ()))
        return pydantic_message(first, _label(where) if where else type(exc).__name__)
    return None


#: pydantic's bound errors and the comparison each states (its ``ctx`` key), for "name == value, must be >= x".
_PYDANTIC_BOUNDS = {"greater_than": (">", "gt"), "greater_than_equal": (">=", "ge"), "less_than": ("<", "lt"),
                    "less_than_equal": ("<=", "le")}


def pydantic_message(error: dict, name: str) -> str:
    """One pydantic error (an item of ``ValidationError.errors()``) as the library words its own:
    ``"--offset-sigma == -1.0, must be >= 0"``; other kinds as ``"name: message (got value)"``."""
    bound = _PYDANTIC_BOUNDS.get(error.get("type"))
    value = error.get("input")
    if bound is not None and bound[1] in (error.get("ctx") or {}):
        limit = error["ctx"][bound[1]]
        limit = f"{limit:g}" if isinstance(limit, (int, float)) else limit
        return f"{name} == {value!r}, must be {bound[0]} {limit}"
    msg = str(error.get("msg", "invalid"))
    msg = msg[len("Value error, "):] if msg.startswith("Value error, ") else msg
    if error.get("type") == "value_error":  # our own validators' messages carry the value already
        return f"{name} {msg}"
    return f"{name}: {msg} (got {value!r})"


@contextmanager
def user_errors():
    """Turn the library's input errors (and a path the system refuses) into one-line errors, exit 2."""
    try:
        yield
    except Exception as exc:
        message = describe(exc)
        if message is None:
            raise
        fail(message)


def human_console(json_mode: bool) -> Console:
    """The console for human-readable output: stderr when stdout carries JSON."""
    return err_console if json_mode else console


#: Off a terminal: the first plain progress line after this many seconds, then one every this many seconds
#: or every tenth of the job, whichever comes first (``CHRONOFUSE_PROGRESS_S`` overrides it).
PLAIN_PROGRESS_S = 5.0


def _eta(elapsed_s: float, fraction: float | None, reached_s: float | None = None) -> float | None:
    """Seconds left by the rate up to when ``fraction`` was reached (``reached_s`` after the start; default
    now), less the time since; None before any fraction is known, or once a stage has outlasted that rate
    (a long stage reports no fraction of its own: an ETA that grows while it runs would mislead)."""
    if fraction is None or fraction <= 0.0:
        return None
    reached_s = elapsed_s if reached_s is None else reached_s
    left = reached_s * (1.0 - fraction) / fraction - (elapsed_s - reached_s)
    return left if left > 0.0 or fraction >= 1.0 else None


def _clock(seconds: float | None) -> str:
    if seconds is None:
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 60}:{seconds % 60:02d}" if seconds >= 60 else f"{seconds} s"


class _PlainProgress:
    """Progress off a terminal: plain lines on stderr, ``label: message, 40 % (12 s gone, ETA 18 s)``, none
    in the first :data:`PLAIN_PROGRESS_S` seconds (a short command prints nothing), then at every tenth of the
    job and, from a timer, every :data:`PLAIN_PROGRESS_S` seconds while a stage lasts."""

    def __init__(self, label: str, interval_s: float):
        import threading

        self.label, self.interval_s = label, interval_s
        self.start = self.last_line = time.monotonic()
        self.message, self.fraction, self.printed_tenth = "working", None, -1
        self.reached = self.start  # when the fraction last changed
        self.lock = threading.Lock()
        self.stop = threading.Event()
        self.ticker = threading.Thread(target=self._tick, name="chronofuse-progress", daemon=True)
        self.ticker.start()

    def _line(self, now: float) -> None:
        elapsed = now - self.start
        done = "" if self.fraction is None else f", {100 * self.fraction:.0f} %"
        eta = _eta(elapsed, self.fraction, self.reached - self.start)
        tail = f" ({_clock(elapsed)} gone" + ("" if eta is None else f", ETA {_clock(eta)}") + ")"
        err_console.print(f"{self.label}: {self.message}{done}{tail}", markup=False, highlight=False, soft_wrap=True)
        self.last_line = now
        if self.fraction is not None:
            self.printed_tenth = int(10 * self.fraction)

    def update(self, message: str | None = None, fraction: float | None = None) -> None:
        with self.lock:
            self.message = message or self.message
            now = time.monotonic()
            if fraction is not None and min(max(float(fraction), 0.0), 1.0) != self.fraction:
                self.fraction, self.reached = min(max(float(fraction), 0.0), 1.0), now
            new_tenth = self.fraction is not None and int(10 * self.fraction) > self.printed_tenth
            if now - self.start >= self.interval_s and new_tenth:
                self._line(now)

    def _tick(self) -> None:
        while not self.stop.wait(min(self.interval_s, 1.0)):
            with self.lock:
                now = time.monotonic()
                if now - self.start >= self.interval_s and now - self.last_line >= self.interval_s:
                    self._line(now)

    def close(self) -> None:
        self.stop.set()
        self.ticker.join()


@contextmanager
def progress_reporter(label: str):
    """Progress of work that may take more than a few seconds, on stderr (stdout stays clean for ``--json``).

    Yields ``say(message=None, fraction=None)`` (:mod:`chronofuse.progress`): the stage now running and,
    where known, the fraction of the job done. On a terminal: a transient bar with the percentage, the time
    gone and the ETA. Off one: plain lines (:class:`_PlainProgress`). ``--quiet``: nothing.
    """
    if err_console.quiet:
        yield lambda message=None, fraction=None: None
        return
    if not err_console.is_terminal:
        interval = float(os.environ.get("CHRONOFUSE_PROGRESS_S", PLAIN_PROGRESS_S))
        plain = _PlainProgress(label, interval)
        try:
            yield plain.update
        finally:
            plain.close()
        return
    columns = (SpinnerColumn(), TextColumn("[bold]{task.description}"), BarColumn(), TaskProgressColumn(),
               TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn())
    with Progress(*columns, console=err_console, transient=True) as bar:
        task = bar.add_task(label, total=None)

        def say(message: str | None = None, fraction: float | None = None) -> None:
            fields = {} if message is None else {"description": f"{label}: {message}"}
            if fraction is not None:
                fields.update(total=1.0, completed=min(max(float(fraction), 0.0), 1.0))
            bar.update(task, **fields)

        yield say


def run_reproduction(label: str, reproduce, out, *, quick: bool, json_out: bool, seed: int | None = None) -> dict | None:
    """Run a ``chronofuse reproduce`` experiment, ``reproduce(out, quick=quick, progress=say[, seed=seed])``, with
    one-line errors and a progress display (``seed`` None: the experiment's published seed); with ``json_out``
    print ``{"out": ..., **summary}`` and return None, else return the summary for the human tables."""
    with user_errors():
        with progress_reporter(label) as say:
            summary = reproduce(out, quick=quick, progress=say, **({} if seed is None else {"seed": seed}))
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
    messages.extend((w.message.render(_label) if isinstance(w.message, InputWarning) else str(w.message)).splitlines()[0]
                    for w in caught)
