"""Plain phase or frequency records (Stable32 / TimeLab style text files).

A record file holds one column (values at a known rate) or two columns (time in seconds, value),
separated by commas or white space; ``#`` (and ``;``) start comments; a first line of names is a
header, and a name's unit suffix (``_s``, ``_ms``, ``_us``, ``_ns``) scales that column to SI; a time
column named ``mjd`` is in days (converted to seconds).
``.gz`` files are read transparently. ``nan`` marks a missing sample (a gap), and so does a step of
the time column that is a whole multiple of the sample interval.

Every problem is reported as :class:`~chronofuse.validation.InputDataError` naming the file and line.
"""

from __future__ import annotations

import gzip
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.io.grid import grid_slots, place_on_grid
from chronofuse.validation import InputDataError, check_choice, check_scalar

KINDS = ("phase", "freq")

_UNIT_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "ps": 1e-12}
_SPLIT = re.compile(r"[,\s;]+")
_SECONDS_PER_DAY = 86_400.0
_TIME_NAMES = {"t", "time", "mjd", "epoch", "t_s", "time_s"}


@dataclass(frozen=True)
class ClockRecord:
    """A phase (seconds) or fractional-frequency record sampled at ``rate_hz``.

    Attributes
    ----------
    values : ndarray of shape (N,)
        Phase in seconds or fractional frequency (dimensionless); NaN marks a gap.
    rate_hz : float
        Sample rate.
    kind : {"phase", "freq"}
    t_s : ndarray of shape (N,) or None
        The time column (seconds, gaps filled in) when the file had one.
    source : str
        Where the record came from (file path).
    n_gaps : int
        Number of missing samples (NaN values plus samples inserted for time-column gaps).
    column : str
        The name (or 1-based number) of the value column read.
    """

    values: np.ndarray
    rate_hz: float
    kind: str
    t_s: np.ndarray | None
    source: str
    n_gaps: int
    column: str


def _open_text(path: Path):
    if path.suffix == ".gz":
        return gzip.open(path, "rt", encoding="utf-8", errors="replace")
    return open(path, encoding="utf-8", errors="replace")


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _unit_scale(name: str) -> float:
    match = re.search(r"_([a-z]+)$", name.lower())
    if match and match.group(1) in _UNIT_SCALE:
        return _UNIT_SCALE[match.group(1)]
    return 1.0


def _read_rows(path: Path) -> tuple[list[str] | None, int, list[tuple[int, list[str]]]]:
    """Return (header names or None, header line number (0 if none), [(line number, tokens)])."""
    header = None
    header_line = 0
    rows: list[tuple[int, list[str]]] = []
    try:
        with _open_text(path) as fh:
            for lineno, raw in enumerate(fh, start=1):
                line = raw.split("#", 1)[0].strip()
                if not line:
                    continue
                tokens = [t for t in _SPLIT.split(line) if t]
                if not tokens:
                    continue
                if header is None and not rows and not all(_is_number(t) for t in tokens):
                    if any(_is_number(t) for t in tokens):
                        bad = next(t for t in tokens if not _is_number(t))
                        raise InputDataError(f"cannot read {bad!r} as a number", str(path), lineno)
                    header, header_line = tokens, lineno
                    continue
                rows.append((lineno, tokens))
    except (OSError, EOFError, gzip.BadGzipFile) as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc
    return header, header_line, rows


def _pick_columns(header, header_line: int, rows, path: Path, column: str | None) -> tuple[int | None, int, str, float, float]:
    """Choose (time index or None, value index, value name, time scale, value scale)."""
    width = len(rows[0][1])
    names = header if header is not None else [str(i + 1) for i in range(width)]
    if header is not None and len(header) != width:
        raise InputDataError(
            f"header has {len(header)} names but the first data line has {width} values", str(path), rows[0][0]
        )
    time_idx = None
    if width >= 2:
        lowered = [n.lower() for n in names]
        time_idx = next((i for i, n in enumerate(lowered) if n in _TIME_NAMES or n.startswith("t_")), 0)
    if column is not None:
        if column in names:
            value_idx = names.index(column)
        elif column.isdigit() and 1 <= int(column) <= width:
            value_idx = int(column) - 1
        else:
            raise InputDataError(f"column {column!r} not found; columns are {names} (or 1..{width})", str(path),
                                 header_line or rows[0][0])
    elif width == 1:
        value_idx = 0
    elif width == 2:
        value_idx = 1 - time_idx
    else:
        raise InputDataError(f"{width} columns {names}: choose the value column with --column", str(path), rows[0][0])
    if value_idx == time_idx:
        time_idx = None
    time_scale = 1.0
    if time_idx is not None:
        time_scale = _SECONDS_PER_DAY if names[time_idx].lower() == "mjd" else _unit_scale(names[time_idx])
    return time_idx, value_idx, names[value_idx], time_scale, _unit_scale(names[value_idx])


def _longest_nan_run(values: np.ndarray) -> tuple[int, int]:
    """(start index, length) of the longest run of NaN in ``values`` (which has at least one)."""
    nan = np.concatenate(([False], np.isnan(values), [False])).astype(np.int8)
    edges = np.diff(nan)
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    k = int(np.argmax(ends - starts))
    return int(starts[k]), int(ends[k] - starts[k])


def read_record(
    path: str | Path,
    *,
    kind: str = "phase",
    rate_hz: float | None = None,
    column: str | None = None,
    nominal_hz: float | None = None,
    max_gap_fraction: float = 0.5,
) -> ClockRecord:
    """Read a phase or frequency record from a text file (optionally gzipped).

    Parameters
    ----------
    path : str or Path
        The file.
    kind : {"phase", "freq"}
        What the values are: phase in seconds (after the column's unit scale) or fractional frequency.
    rate_hz : float, optional
        Sample rate. Required for one-column files; for files with a time column it is derived from
        the time column, and a given value must agree with it.
    column : str, optional
        Name (from the header) or 1-based number of the value column.
    nominal_hz : float, optional
        For ``kind="freq"`` files holding absolute frequency in Hz (a counter's readings): the
        nominal frequency, so that ``y = f / nominal_hz - 1``. Without it, frequency values whose
        magnitude exceeds 1e-3 are rejected as being in the wrong unit.
    max_gap_fraction : float
        A record whose gaps exceed this fraction of its samples is rejected (too little data).

    Raises
    ------
    InputDataError
        Empty file, text where numbers are expected, a ragged line, non-monotonic time, a time step
        that is not a whole number of sample intervals, a rate that does not match the time column,
        or a record made mostly of gaps: each names the file and line.
    """
    path = Path(path)
    check_choice(kind, "kind", KINDS)
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    if not path.exists():
        raise InputDataError("no such file", str(path))
    if path.is_dir():
        raise InputDataError("is a directory, not a data file", str(path))
    header, header_line, rows = _read_rows(path)
    if not rows:
        raise InputDataError("no data lines (empty file, or only comments and a header)", str(path))
    time_idx, value_idx, name, t_scale, v_scale = _pick_columns(header, header_line, rows, path, column)
    width = len(rows[0][1])

    values = np.empty(len(rows))
    times = np.empty(len(rows)) if time_idx is not None else None
    for i, (lineno, tokens) in enumerate(rows):
        if len(tokens) != width:
            raise InputDataError(f"{len(tokens)} values on this line, expected {width}", str(path), lineno)
        try:
            values[i] = float(tokens[value_idx])
            if times is not None:
                times[i] = float(tokens[time_idx])
        except ValueError:
            bad = next(t for t in tokens if not _is_number(t))
            raise InputDataError(f"cannot read {bad!r} as a number", str(path), lineno) from None
    if np.isinf(values).any():
        lineno = rows[int(np.flatnonzero(np.isinf(values))[0])][0]
        raise InputDataError("infinite value", str(path), lineno)
    values = values * v_scale

    sample_line = np.array([lineno for lineno, _ in rows])  # file line of each sample (-1: inserted gap)
    t_out = None
    if times is not None:
        if np.isnan(times).any():
            lineno = rows[int(np.flatnonzero(np.isnan(times))[0])][0]
            raise InputDataError("missing time value", str(path), lineno)
        t0_s = times[0] * t_scale
        times = (times - times[0]) * t_scale  # relative first: MJD days * 86400 keep their precision
        steps = np.diff(times)
        if (steps <= 0).any():
            k = int(np.flatnonzero(steps <= 0)[0]) + 1
            raise InputDataError(
                f"time is not increasing ({t0_s + times[k - 1]:g} s then {t0_s + times[k]:g} s)", str(path), rows[k][0]
            )
        if steps.size:
            interval = float(np.min(steps))
            derived = 1.0 / interval
            if rate_hz is not None and not math.isclose(derived, rate_hz, rel_tol=1e-6):
                raise InputDataError(
                    f"rate {rate_hz:g} Hz does not match the time column (interval {interval:g} s, i.e. "
                    f"{derived:g} Hz)",
                    str(path),
                    rows[int(np.argmin(steps)) + 1][0],
                )
            rate_hz = derived
            index, bad = grid_slots(times, interval, 1e-6)
            if bad >= 0:
                raise InputDataError(
                    f"time step {steps[bad - 1]:g} s is not a whole number of {interval:g} s sample intervals",
                    str(path),
                    rows[bad][0],
                )
            values = place_on_grid(index, values)
            sample_line = np.full(values.size, -1)
            sample_line[index] = [lineno for lineno, _ in rows]
            t_out = t0_s + np.arange(values.size) / rate_hz
        else:
            t_out = t0_s + times
    if rate_hz is None:
        raise InputDataError("one-column file: give the sample rate (--rate HZ)", str(path))

    if kind == "freq":
        if nominal_hz is not None:
            check_scalar(nominal_hz, "nominal_hz", min_val=0, include_min=False)
            values = values / nominal_hz - 1.0
        elif np.nanmax(np.abs(values)) > 1e-3:
            k = int(np.nanargmax(np.abs(values)))
            raise InputDataError(
                f"frequency value {values[k]:g} is not a fractional frequency (|y| > 1e-3): "
                "for absolute frequency in Hz give the nominal frequency (--nominal-hz)",
                str(path),
                rows[min(k, len(rows) - 1)][0],
            )

    n_gaps = int(np.isnan(values).sum())
    if n_gaps == values.size:
        raise InputDataError("every value is missing (NaN)", str(path), rows[0][0])
    if n_gaps > max_gap_fraction * values.size:
        start, length = _longest_nan_run(values)
        line = sample_line[start] if sample_line[start] >= 0 else sample_line[max(start - 1, 0)]
        raise InputDataError(
            f"{n_gaps} of {values.size} samples are missing (NaN runs or time gaps; the longest, {length} samples, "
            f"starts here); too little data",
            str(path),
            int(line),
        )
    return ClockRecord(
        values=values,
        rate_hz=float(rate_hz),
        kind=kind,
        t_s=t_out,
        source=str(path),
        n_gaps=n_gaps,
        column=name,
    )


def column_names(path: str | Path) -> list[str] | None:
    """The header names of a record file as :func:`read_record` reads them, or None when it has no header."""
    header, _, _ = _read_rows(Path(path))
    return header
