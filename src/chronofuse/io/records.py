"""Plain phase or frequency records (Stable32 / TimeLab / counter-log style text files).

A record file holds one column (values at a known rate) or two columns (time, value), or more with a
header naming them; ``#`` (and ``;``) start comments; a first line of names is a header, and a name's
unit suffix (``_s``, ``_ms``, ``_us``, ``_ns``, ``_ps``) scales that column to SI; a time column named
``mjd`` is in days. The layout (compression by content, BOM, delimiter, decimal comma) is sniffed by
:mod:`chronofuse.io.columns`, which reads the columns with pyarrow's CSV reader.

Time columns are read as text and converted to integer nanoseconds exactly (``int_part * ns_per_unit +
fraction``): an absolute epoch is never one float64. The sample interval is the median time step
(robust to gaps and jitter), refined by least squares over the whole record and snapped to a round
value (6 significant digits of the interval or of the rate) when that moves no sample to another slot.
Each sample goes to the nearest slot of that grid; a sample more than a quarter interval from its slot
is refused (it is not on a regular grid); the rms and largest offset from the slots are reported
(``jitter_rms_s``, ``jitter_max_s``), and missing slots become gaps (NaN). ``rate_hz``, when given with a
time column, sets the interval; when it disagrees with the time column (by more than 1e-3 relative)
it overrides it with a warning, and the samples are taken as consecutive.

``nan`` marks a missing sample. Frequency records: fractional frequency is analysed whatever its size,
with a warning above 1e-3 (implausible for a clock); values that are clearly an absolute frequency
(all of one sign, above 1e-3 and a spread under 1e-3 of their mean: a counter's readings in Hz or a
frequency normalised to 1) are refused unless ``nominal_hz`` is given.

Every problem is reported as :class:`~chronofuse.validation.InputDataError` naming the file and line.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.io.columns import Layout, data_lines, decimal_text_to_ns, read_columns, sniff
from chronofuse.io.formats import capture_format
from chronofuse.record import EpochRecord
from chronofuse.timescale import NS_PER_S, SECONDS_PER_DAY
from chronofuse.validation import InputDataError, check_choice, check_scalar

__all__ = ["ClockRecord", "read_record", "capture_record", "epoch_record", "KINDS"]

KINDS = ("phase", "freq")

_UNIT_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9, "ps": 1e-12}
_TIME_NAMES = {"t", "time", "mjd", "epoch", "t_s", "time_s", "unix", "timestamp"}
# A sample further than this fraction of the interval from its grid slot is not on a regular grid.
_SLOT_TOLERANCE = 0.25
# --rate and the time column agree when their intervals differ by less than this (relative).
_RATE_AGREEMENT = 1e-3
# Fractional frequency beyond this magnitude is implausible for a clock (warned, or refused when narrow).
_PLAUSIBLE_Y = 1e-3


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
    t_ns : ndarray of int64 of shape (N,) or None
        Epoch of each grid slot in integer nanoseconds on the file's own time scale (UNIX, MJD, ...), when
        the file had a time column.
    source : str
        Where the record came from (file path).
    n_gaps : int
        Number of missing samples (NaN values plus slots the time column skipped).
    column : str
        The name (or 1-based number) of the value column read.
    jitter_rms_s, jitter_max_s : float
        Rms and largest distance of the time tags from their grid slots (0 without a time column).
    """

    values: np.ndarray
    rate_hz: float
    kind: str
    t_ns: np.ndarray | None
    source: str
    n_gaps: int
    column: str
    jitter_rms_s: float = 0.0
    jitter_max_s: float = 0.0

    @property
    def t_s(self) -> np.ndarray | None:
        """Seconds since the first sample (a duration, float64), shape (N,), or None without a time column."""
        if self.t_ns is None:
            return None
        return (self.t_ns - self.t_ns[0]) / NS_PER_S


def _unit_scale(name: str) -> float:
    match = re.search(r"_([a-z]+)$", name.lower())
    if match and match.group(1) in _UNIT_SCALE:
        return _UNIT_SCALE[match.group(1)]
    return 1.0


def _time_ns_per_unit(name: str) -> int:
    """Nanoseconds per unit of a time column named ``name`` (``mjd``: days; ``_ms``, ``_us``, ``_ns``)."""
    lowered = name.lower()
    if lowered == "mjd" or lowered.startswith("mjd_"):
        return SECONDS_PER_DAY * NS_PER_S
    match = re.search(r"_([a-z]+)$", lowered)
    return {"ms": 1_000_000, "us": 1_000, "ns": 1}.get(match.group(1) if match else "", NS_PER_S)


def _pick_columns(layout: Layout, path: Path, column: str | None) -> tuple[int | None, int, str]:
    """Choose (time index or None, value index, value name)."""
    width, header = layout.width, layout.header
    names = header if header is not None else [str(i + 1) for i in range(width)]
    if header is not None and len(header) != width:
        raise InputDataError(
            f"header has {len(header)} names but the first data line has {width} values", str(path),
            layout.first_data_line
        )
    time_idx = None
    if width >= 2:
        lowered = [n.lower() for n in names]
        time_idx = next((i for i, n in enumerate(lowered) if n in _TIME_NAMES or n.startswith(("t_", "mjd"))), 0)
    if column is not None:
        if column in names:
            value_idx = names.index(column)
        elif column.isdigit() and 1 <= int(column) <= width:
            value_idx = int(column) - 1
        else:
            raise InputDataError(f"column {column!r} not found; columns are {names} (or 1..{width})", str(path),
                                 layout.header_line or layout.first_data_line)
    elif width == 1:
        value_idx = 0
    elif width == 2:
        value_idx = 1 - time_idx
    else:
        raise InputDataError(f"{width} columns {names}: choose the value column with --column", str(path),
                             layout.first_data_line)
    if value_idx == time_idx:
        time_idx = None
    return time_idx, value_idx, names[value_idx]


def _line_of(path: Path, layout: Layout, k: int) -> int:
    """1-based file line of data sample ``k`` (a second, line-by-line pass: only for error messages)."""
    for i, (lineno, _) in enumerate(data_lines(path, layout)):
        if i == k:
            return lineno
    return layout.first_data_line


def _longest_nan_run(values: np.ndarray) -> tuple[int, int]:
    """(start index, length) of the longest run of NaN in ``values`` (which has at least one)."""
    nan = np.concatenate(([False], np.isnan(values), [False])).astype(np.int8)
    edges = np.diff(nan)
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    k = int(np.argmax(ends - starts))
    return int(starts[k]), int(ends[k] - starts[k])


def _snap(interval_ns: float) -> list[float]:
    """Round candidates for an interval (ns): 6 significant digits of the interval and of the rate."""
    rate = 1e9 / interval_ns
    return [float(f"{interval_ns:.6g}"), 1e9 / float(f"{rate:.6g}")]


@dataclass(frozen=True)
class _Grid:
    slots: np.ndarray  # int64 (N,): slot of each sample, slots[0] == 0
    interval_ns: float
    start_ns: float  # grid slot 0 is at t[0] + start_ns
    jitter_rms_s: float
    jitter_max_s: float


def _time_grid(t_ns: np.ndarray, rate_hz: float | None, path: Path, layout: Layout) -> _Grid | None:
    """Place integer-ns time tags (N,) on a regular grid; None when ``rate_hz`` overrides the time column.

    Each step is a whole number of intervals (within ``_SLOT_TOLERANCE``): the slots are the running sum
    of those numbers, so timing jitter never accumulates along the record; the interval is then the
    least-squares slope of offset against slot, snapped to a round value when that changes no slot.
    """
    steps = np.diff(t_ns)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputDataError(
            f"time is not increasing ({t_ns[k - 1] / NS_PER_S:.9g} s then {t_ns[k] / NS_PER_S:.9g} s on the file's "
            "scale)", str(path), _line_of(path, layout, k))
    first_guess = float(np.partition(steps, (steps.size - 1) // 2)[(steps.size - 1) // 2])  # lower median
    if rate_hz is not None:
        given = 1e9 / rate_hz
        if abs(given - first_guess) > _RATE_AGREEMENT * first_guess:
            warnings.warn(
                f"{path}: --rate {rate_hz:g} Hz overrides the time column (median step {first_guess / 1e9:.9g} s, "
                f"i.e. {1e9 / first_guess:.9g} Hz): samples taken as consecutive at {rate_hz:g} Hz", stacklevel=3)
            return None
        first_guess = given
    ratio = steps / first_guess
    counts = np.rint(ratio).astype(np.int64)
    bad = np.flatnonzero((np.abs(ratio - counts) > _SLOT_TOLERANCE) | (counts < 1))
    if bad.size:
        k = int(bad[0])
        raise InputDataError(
            f"time step {steps[k] / 1e9:.9g} s is not a whole number of {first_guess / 1e9:.9g} s sample intervals "
            f"(the median step; tolerance {_SLOT_TOLERANCE} of an interval)", str(path), _line_of(path, layout, k + 1))
    slots = np.concatenate(([0], np.cumsum(counts)))
    offsets = (t_ns - t_ns[0]).astype(np.float64)
    if rate_hz is not None:
        interval = first_guess
    else:  # least-squares line offset = start + interval * slot
        sc = slots - slots.mean()
        interval = float(np.dot(sc, offsets - offsets.mean()) / np.dot(sc, sc))
        for candidate in _snap(interval):
            if abs(candidate - interval) * slots[-1] < 0.01 * interval:
                interval = candidate
                break
    resid = offsets - slots * interval
    start = float(np.mean(resid))  # the grid's phase against the first time tag
    resid -= start
    return _Grid(slots, interval, start, float(np.sqrt(np.mean(resid**2))) / 1e9, float(np.abs(resid).max()) / 1e9)


def _check_frequency(values: np.ndarray, path: Path, nominal_hz: float | None) -> np.ndarray:
    """Fractional frequency from the values (absolute frequency with ``nominal_hz``), see module docstring."""
    if nominal_hz is not None:
        check_scalar(nominal_hz, "nominal_hz", min_val=0, include_min=False)
        return values / nominal_hz - 1.0
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return values
    largest = float(np.max(np.abs(finite)))
    if largest <= _PLAUSIBLE_Y:
        return values
    mean = float(np.mean(finite))
    spread = float(np.std(finite))
    one_sign = bool(np.all(finite > 0) or np.all(finite < 0))
    if one_sign and abs(mean) > _PLAUSIBLE_Y and spread < _PLAUSIBLE_Y * abs(mean):
        raise InputDataError(
            f"frequency values of mean {mean:.9g} with a relative spread of {spread / abs(mean):.1e} look like an "
            "absolute (or normalised) frequency, not a fractional one: give the nominal frequency (--nominal-hz)",
            str(path))
    warnings.warn(
        f"{path}: fractional frequency up to {largest:.3g} in magnitude is implausible for a clock (|y| > "
        f"{_PLAUSIBLE_Y:g}); analysed as given (for absolute frequency in Hz give --nominal-hz)", stacklevel=3)
    return values


def read_record(
    path: str | Path,
    *,
    kind: str = "phase",
    rate_hz: float | None = None,
    column: str | None = None,
    nominal_hz: float | None = None,
    max_gap_fraction: float = 0.5,
    station: str | None = None,
) -> ClockRecord:
    """Read a phase or frequency record from a text file (plain, gzip, bz2 or xz, told by content), or a
    receiver recording's clock (:func:`capture_record`).

    Parameters
    ----------
    path : str or Path
        The file.
    kind : {"phase", "freq"}
        What the values are: phase in seconds (after the column's unit scale) or fractional frequency.
    rate_hz : float, optional
        Sample rate. Required for one-column files; with a time column it sets the grid interval, and
        overrides the time column (with a warning) where the two disagree.
    column : str, optional
        Name (from the header) or 1-based number of the value column.
    nominal_hz : float, optional
        For ``kind="freq"`` files holding absolute frequency in Hz (a counter's readings): the nominal
        frequency, so that ``y = f / nominal_hz - 1``.
    max_gap_fraction : float
        A record whose gaps exceed this fraction of its samples is rejected (too little data).
    station : str, optional
        The station of a RINEX clock product (the first without it); refused for any other file.

    Raises
    ------
    InputDataError
        Empty file, an archive, text where numbers are expected, an ambiguous decimal comma, a ragged line,
        non-monotonic time, a time tag off the regular grid, absolute frequency without ``nominal_hz``, or
        a record made mostly of gaps: each names the file and, where there is one, the line.
    """
    path = Path(path)
    check_choice(kind, "kind", KINDS)
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    if not path.exists():
        raise InputDataError("no such file", str(path))
    if path.is_dir():
        raise InputDataError("is a directory, not a data file", str(path))
    if capture_format(path) is not None:  # a receiver recording (UBX, NMEA): its clock bias / drift
        return capture_record(path, kind=kind, rate_hz=rate_hz, station=station)
    if station is not None:
        raise InputDataError("--station picks a station of a RINEX clock product (.clk), not of a text record",
                             str(path))
    layout = sniff(path)
    time_idx, value_idx, name = _pick_columns(layout, path, column)
    try:
        values, time_text, _ = read_columns(path, layout, value_idx, time_idx)
    except (OSError, EOFError) as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc
    if values.size == 0:
        raise InputDataError("no data lines (empty file, or only comments and a header)", str(path))
    if np.isinf(values).any():
        raise InputDataError("infinite value", str(path), _line_of(path, layout, int(np.flatnonzero(np.isinf(values))[0])))
    scale = 1.0 if layout.header is None else _unit_scale(name)
    if scale != 1.0:
        values = values * scale

    t_ns, grid = None, None
    jitter = (0.0, 0.0)
    sample_of_slot = None  # sample index at each slot (-1: a slot the time column skipped)
    if time_text is not None:
        t_name = layout.header[time_idx] if layout.header is not None else "t"
        t_raw, bad = decimal_text_to_ns(time_text, _time_ns_per_unit(t_name))
        if bad >= 0:
            raise InputDataError(f"cannot read {time_text[bad].as_py()!r} as a time", str(path),
                                 _line_of(path, layout, bad))
        if t_raw.size >= 2:
            grid = _time_grid(t_raw, rate_hz, path, layout)
        if grid is not None:
            rate_hz = 1e9 / grid.interval_ns
            placed = np.full(int(grid.slots[-1]) + 1, np.nan)
            placed[grid.slots] = values
            sample_of_slot = np.full(placed.size, -1, dtype=np.int64)
            sample_of_slot[grid.slots] = np.arange(values.size)
            values = placed
            t_ns = t_raw[0] + np.rint(grid.start_ns + np.arange(values.size) * grid.interval_ns).astype(np.int64)
            jitter = (grid.jitter_rms_s, grid.jitter_max_s)
        elif rate_hz is not None and t_raw.size >= 2:
            t_ns = t_raw[0] + np.rint(np.arange(values.size) * (1e9 / rate_hz)).astype(np.int64)
        else:
            t_ns = t_raw
    if rate_hz is None:
        raise InputDataError("one-column file: give the sample rate (--rate HZ)", str(path))

    if kind == "freq":
        values = _check_frequency(values, path, nominal_hz)

    n_gaps = int(np.isnan(values).sum())
    if n_gaps == values.size:
        raise InputDataError("every value is missing (NaN)", str(path), layout.first_data_line)
    if n_gaps > max_gap_fraction * values.size:
        start, length = _longest_nan_run(values)
        if sample_of_slot is not None:
            k = sample_of_slot[start] if sample_of_slot[start] >= 0 else sample_of_slot[max(start - 1, 0)]
        else:
            k = start
        raise InputDataError(
            f"{n_gaps} of {values.size} samples are missing (NaN runs or time gaps; the longest, {length} samples, "
            f"starts here); too little data",
            str(path),
            _line_of(path, layout, int(max(k, 0))),
        )
    return ClockRecord(
        values=values,
        rate_hz=float(rate_hz),
        kind=kind,
        t_ns=t_ns,
        source=str(path),
        n_gaps=n_gaps,
        column=name,
        jitter_rms_s=jitter[0],
        jitter_max_s=jitter[1],
    )


def capture_record(path: str | Path, kind: str = "phase", rate_hz: float | None = None,
                   station: str | None = None) -> ClockRecord:
    """A recording's clock as the phase or frequency record ``chronofuse stability`` analyses: the clock
    bias (phase, s) or the clock drift (``kind="freq"``: fractional frequency, s/s) on the recording's grid
    (:func:`chronofuse.io.capture_series.capture_clock_series`; ``rate_hz`` sets the interval), gaps as
    NaN; ``t_ns`` holds the GPS epochs. A RINEX clock product gives ``station``'s clock, or without one its
    first station's (with a warning naming it); ``station`` on any other recording is refused naming the file."""
    # the receiver parsers (pyubx2, pynmeagps) only when a recording is read: text records need none of them
    from chronofuse.io.capture_series import capture_clock_series
    from chronofuse.io.inspect import read_capture

    check_choice(kind, "kind", KINDS)
    capture = read_capture(path, receiver=station)
    if station is not None and "rinex-clock" not in capture.protocols:
        raise InputDataError("--station picks a station of a RINEX clock product (.clk); this recording has "
                             "one receiver", str(path))
    if station is None and len(capture.receivers) > 1:
        warnings.warn(f"{path}: a RINEX clock product of {len(capture.receivers)} stations: the first, "
                      f"{capture.receivers[0]}, is analysed (--station picks any)", stacklevel=2)
    series = capture_clock_series(capture, rate_hz)
    column = "clock_bias_s" if kind == "phase" else "clock_drift_s_per_s"
    values = np.asarray(series.column(column, np.nan), dtype=np.float64)
    if np.isnan(values).all():
        raise InputDataError(f"every {column} value is missing", series.source)
    return ClockRecord(values=values, rate_hz=1e9 / series.interval_ns, kind=kind, t_ns=np.asarray(series.t_ns),
                       source=series.source, n_gaps=int(np.isnan(values).sum()), column=column,
                       jitter_rms_s=series.info["jitter_rms_s"], jitter_max_s=series.info["jitter_max_s"])


def epoch_record(record: ClockRecord, column: str | None = None) -> EpochRecord:
    """A :class:`ClockRecord` as the one epoch record: its values as column ``column`` (default: the record's
    own column name, its unit suffix made SI: ``clock_bias_ns`` -> ``clock_bias_s``), unit ``s`` for phase
    and ``s/s`` for frequency, on its grid (``interval_ns``); ``t_ns`` on the file's axis (its time column
    in ns, or the sample number times the interval without one). Provenance: each value's 0-based sample
    index (the file line is :func:`_line_of` of it)."""
    name = column or _si_name(record.column, record.kind)
    interval_ns = int(round(1e9 / record.rate_hz))
    t_ns = record.t_ns if record.t_ns is not None else np.arange(record.values.size, dtype=np.int64) * interval_ns
    return EpochRecord.from_arrays(t_ns, {name: record.values}, {name: "s" if record.kind == "phase" else "s/s"},
                                   source=record.source, interval_ns=interval_ns, time_scale="file",
                                   info={"n_gaps": record.n_gaps, "jitter_rms_s": record.jitter_rms_s,
                                         "jitter_max_s": record.jitter_max_s})


def _si_name(name: str, kind: str) -> str:
    stem = re.sub(r"_([a-z]+)$", "", name.lower()) if _unit_scale(name) != 1.0 or name.lower().endswith("_s") else name
    return f"{stem}_s" if kind == "phase" else stem


def column_names(path: str | Path) -> list[str] | None:
    """The header names of a record file as :func:`read_record` reads them, or None when it has no header."""
    return sniff(Path(path)).header
