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
from fractions import Fraction
from pathlib import Path

import numpy as np
import pyarrow as pa

from chronofuse.io.clock_record import ClockRecord
from chronofuse.io.columns import Layout, data_lines, decimal_text_to_ns, read_columns, sniff
from chronofuse.io.formats import capture_format, log_format
from chronofuse.io.record_columns import (
    ColumnChoice,
    check_frequency,
    check_phase_steps,
    choose_columns,
    record_notes,
    time_ns_per_unit,
    to_si,
)
from chronofuse.io.timestamps import date_time_to_ns, infer_time_unit, is_date_time
from chronofuse.io.units import header_facts
from chronofuse.record import EpochRecord
from chronofuse.timescale import NS_PER_S, SECONDS_PER_DAY
from chronofuse.validation import InputDataError, InputError, InputWarning, check_choice, check_scalar

__all__ = ["ClockRecord", "read_record", "capture_record", "epoch_record", "KINDS"]

KINDS = ("phase", "freq")

# A sample further than this fraction of the interval from its grid slot is not on a regular grid.
_SLOT_TOLERANCE = 0.25
# rate_hz and the time column agree when their intervals differ by less than this (relative).
_RATE_AGREEMENT = 1e-3


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


def _median_step(t_ns: np.ndarray, path: Path, layout: Layout) -> float:
    """The lower median of the steps of ``t_ns`` (N,); a step that does not advance is an error naming its line."""
    steps = np.diff(t_ns)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputDataError(
            f"time is not increasing ({int(t_ns[k - 1])} ns then {int(t_ns[k])} ns on the file's "
            "scale)", str(path), _line_of(path, layout, k))
    return float(np.partition(steps, (steps.size - 1) // 2)[(steps.size - 1) // 2])


def _overridden(first_guess: float, rate_hz: float | None, path: Path) -> float | None:
    """The interval (ns) to use: the median step, or ``--rate``'s; None when ``--rate`` overrides the column."""
    if rate_hz is None:
        return first_guess
    given = 1e9 / rate_hz
    if abs(given - first_guess) > _RATE_AGREEMENT * first_guess:
        warnings.warn(InputWarning(
            f"{path}: {{rate_hz}} {rate_hz:g} Hz overrides the time column (median step {first_guess / 1e9:.9g} s, "
            f"i.e. {1e9 / first_guess:.9g} Hz): samples taken as consecutive at {rate_hz:g} Hz", fields=("rate_hz",)),
            stacklevel=4)
        return None
    return given


def _bad_step(t_ns: np.ndarray, k: int, guess: float, path: Path, layout: Layout) -> InputDataError:
    step = t_ns[k] - t_ns[k - 1]
    return InputDataError(
        f"time step {step / 1e9:.9g} s is not a whole number of {guess / 1e9:.9g} s sample intervals "
        f"(the median step; tolerance {_SLOT_TOLERANCE} of an interval)", str(path), _line_of(path, layout, k))


def _time_grid(t_ns: np.ndarray, rate_hz: float | None, path: Path, layout: Layout) -> _Grid | None:
    """Place integer-ns time tags (N,) on a regular grid; None when ``rate_hz`` overrides the time column.

    Each step is a whole number of intervals (within ``_SLOT_TOLERANCE``): the slots are the running sum
    of those numbers, so timing jitter never accumulates along the record; the interval is then the
    least-squares slope of offset against slot, snapped to a round value when that changes no slot. The
    passes over the tags are numba loops (:mod:`chronofuse.io.kernels_time`); :func:`_time_grid_numpy` is
    their twin.
    """
    from chronofuse.io.kernels_time import centred_slope, grid_pass, residual_pass

    guess = _overridden(_median_step(t_ns, path, layout), rate_hz, path)
    if guess is None:
        return None
    slots = np.empty(t_ns.size, dtype=np.int64)
    bad, sums = grid_pass(t_ns, guess, _SLOT_TOLERANCE, slots)
    if bad >= 0:
        raise _bad_step(t_ns, bad, guess, path, layout)
    if rate_hz is not None:
        interval = guess
    else:
        interval = centred_slope(t_ns, slots, sums[0] / t_ns.size, sums[1] / t_ns.size)
        interval = _snapped(interval, int(slots[-1]))
    start, rms, peak = residual_pass(t_ns, slots, interval)
    return _Grid(slots, interval, start, rms / 1e9, peak / 1e9)


#: Time tags are quantised when their resolution (the largest step dividing every tag's offset) is at least
#: this fraction of the mean step and the mean step is no whole number of it (MJD with 5 decimals: 0.864 s).
QUANTISED_FRACTION = 0.05
#: ... and there are at least this many tags (three tags off a grid are no evidence of a resolution).
QUANTISED_MIN_TAGS = 16


def _quantised_grid(t_ns: np.ndarray, path: Path) -> _Grid | None:
    """The grid of time tags whose resolution is comparable to their step (MJD days with 5 decimals: 0.864 s
    steps and 1.728 s steps for a 1 s record, which the median-step grid read as 1.157 Hz with gaps), or None
    for tags that are not quantised. The interval is the mean step rounded to 3 significant digits, taken
    (with a warning) when every tag lies within half its resolution of a slot of it and no two share one;
    quantised tags that fit no such interval are warned, and read by the usual grid."""
    if t_ns.size < QUANTISED_MIN_TAGS:
        return None
    offsets = t_ns - t_ns[0]
    quantum = int(np.gcd.reduce(offsets[1:]))
    mean = float(offsets[-1]) / (offsets.size - 1)
    if quantum <= 0 or quantum < QUANTISED_FRACTION * mean:
        return None
    ratio = mean / quantum
    if abs(ratio - round(ratio)) < 0.02:
        return None  # the steps are whole numbers of the resolution: the usual grid reads them
    candidate = float(f"{mean:.3g}")
    slots = np.rint(offsets / candidate).astype(np.int64)
    resid = offsets - slots * candidate
    if np.all(np.diff(slots) >= 1) and np.abs(resid).max() <= 0.5 * quantum * (1 + 1e-9):
        start = float(np.mean(resid))
        resid = resid - start
        warnings.warn(InputWarning(
            f"{path}: the time tags have a resolution of {quantum / 1e9:.6g} s, comparable to their step (mean "
            f"{mean / 1e9:.6g} s): read on a {candidate / 1e9:.6g} s grid, every tag within half its resolution of "
            "its slot (give {rate_hz} to set the interval)", fields=("rate_hz",)), stacklevel=3)
        return _Grid(slots, candidate, start, float(np.sqrt(np.mean(resid**2))) / 1e9, float(np.abs(resid).max()) / 1e9)
    warnings.warn(InputWarning(
        f"{path}: the time tags have a resolution of {quantum / 1e9:.6g} s, comparable to their step (mean "
        f"{mean / 1e9:.6g} s), and fit no regular interval within it: the grid read from them may hold invented "
        "gaps; give {rate_hz} to take the samples as consecutive", fields=("rate_hz",)), stacklevel=3)
    return None


def _snapped(interval: float, last_slot: int) -> float:
    for candidate in _snap(interval):
        if abs(candidate - interval) * last_slot < 0.01 * interval:
            return candidate
    return interval


def _time_grid_numpy(t_ns: np.ndarray, rate_hz: float | None, path: Path, layout: Layout) -> _Grid | None:
    """The readable twin of :func:`_time_grid` (whole-array numpy; several arrays of N on the way)."""
    guess = _overridden(_median_step(t_ns, path, layout), rate_hz, path)
    if guess is None:
        return None
    steps = np.diff(t_ns)
    ratio = steps / guess
    counts = np.rint(ratio).astype(np.int64)
    bad = np.flatnonzero((np.abs(ratio - counts) > _SLOT_TOLERANCE) | (counts < 1))
    if bad.size:
        raise _bad_step(t_ns, int(bad[0]) + 1, guess, path, layout)
    slots = np.concatenate(([0], np.cumsum(counts)))
    offsets = (t_ns - t_ns[0]).astype(np.float64)
    if rate_hz is not None:
        interval = guess
    else:  # least-squares line offset = start + interval * slot
        sc = slots - slots.mean()
        interval = _snapped(float(np.dot(sc, offsets - offsets.mean()) / np.dot(sc, sc)), int(slots[-1]))
    resid = offsets - slots * interval
    start = float(np.mean(resid))  # the grid's phase against the first time tag
    resid -= start
    return _Grid(slots, interval, start, float(np.sqrt(np.mean(resid**2))) / 1e9, float(np.abs(resid).max()) / 1e9)


def read_record(
    path: str | Path,
    *,
    kind: str | None = None,
    rate_hz: float | None = None,
    column: str | None = None,
    nominal_hz: float | None = None,
    max_gap_fraction: float = 0.5,
    station: str | None = None,
    zero_is_gap: bool = False,
) -> ClockRecord:
    """Read a phase or frequency record from a text file (plain, gzip, bz2 or xz, told by content), a
    receiver recording's clock (:func:`capture_record`), or a clock of a field log
    (:func:`chronofuse.io.field_logs.log_record`: ptp4l/phc2sys/ts2phc, chrony, RTKLIB .stat, gpsd JSON,
    Trimble TSIP; ``column`` then names one of its columns).

    Parameters
    ----------
    path : str or Path
        The file.
    kind : {"phase", "freq"}, optional
        What the values are: phase (seconds after the column's unit) or fractional frequency. By default
        from the value column's unit or name (:mod:`chronofuse.io.record_columns`), phase without either;
        a kind that contradicts the unit is refused.
    rate_hz : float, optional
        Sample rate. Required for one-column files unless a header line states the sample interval; with a
        time column it sets the grid interval, and overrides the time column (with a warning) where the two
        disagree.
    column : str, optional
        Name (from the header) or 1-based number of the value column.
    nominal_hz : float, optional
        For frequency in Hz: the nominal frequency, so that ``y = f / nominal_hz - 1`` (a counter's readings)
        or ``y = df / nominal_hz`` (a column of frequency offsets in Hz, told by values far from nominal).
    max_gap_fraction : float
        A record whose gaps exceed this fraction of its samples is rejected (too little data).
    station : str, optional
        The station of a RINEX clock product, or the clock of a field log (its name or a unique part of it:
        ``ptp4l``, ``phc2sys``, a chrony source; :func:`chronofuse.io.field_logs.pick_series`); the first
        without it; refused for any other file.
    zero_is_gap : bool
        Read a value of exactly 0 as a missing sample (Stable32's convention for gaps).

    Raises
    ------
    InputDataError
        Empty file, an archive, text where numbers are expected, an ambiguous decimal comma or date, a ragged
        line, non-monotonic time, a time tag off the regular grid, a unit that contradicts ``kind``, frequency
        in Hz without ``nominal_hz``, or a record made mostly of gaps: each names the file and, where there is
        one, the line.
    """
    path = Path(path)
    if kind is not None:
        check_choice(kind, "kind", KINDS)
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    if not path.exists():
        raise InputDataError("no such file", str(path))
    if path.is_dir():
        raise InputDataError("is a directory, not a data file", str(path))
    if capture_format(path) is not None:  # a receiver recording (UBX, NMEA): its clock bias / drift
        return capture_record(path, kind=kind or "phase", rate_hz=rate_hz, station=station)
    if log_format(path) is not None:  # a field log (linuxptp, chrony, RTKLIB, gpsd, TSIP): one of its clocks
        from chronofuse.io.field_logs import log_record

        return log_record(path, kind=kind, rate_hz=rate_hz, column=column, clock=station)
    from chronofuse.io.ticc import read_ticc, ticc_mode

    mode = ticc_mode(path) if station is None else None
    if mode is not None:  # a TAPR TICC log: "8.737740891687 chA" or "0.000000100012 TI(A->B)" lines
        return read_ticc(path, mode, kind=kind, rate_hz=rate_hz, column=column)
    if station is not None:
        raise InputError("{station} picks a station of a RINEX clock product (.clk) or a clock of a field log, "
                         "not a column of a text record", str(path), fields=("station",))
    layout = sniff(path)
    facts = header_facts(list(layout.comments) + list(layout.preamble))
    first_row = list(layout.rows[0])
    choice = choose_columns(layout, path, column, kind, facts, first_row, is_date_time)
    notes = record_notes(layout, choice, facts)
    stamped = choice.time_field is not None and (layout.pair == choice.time_field
                                                 or is_date_time(first_row[choice.time_field]))
    per_unit = None
    if choice.time_field is not None and not stamped:
        per_unit = _numeric_time_unit(path, layout, choice, facts)
    try:
        values, time_data, _ = read_columns(path, layout, choice.value_field, choice.time_field, per_unit)
    except (OSError, EOFError) as exc:
        raise InputDataError(f"cannot read file: {exc}", str(path)) from exc
    if values.size == 0:
        raise InputDataError("no data lines (empty file, or only comments and a header)", str(path))
    if np.isinf(values).any():
        raise InputDataError("infinite value", str(path), _line_of(path, layout, int(np.flatnonzero(np.isinf(values))[0])))
    if zero_is_gap:
        values = np.where(values == 0.0, np.nan, values)
    _warn_outliers(values, path, layout)
    values = to_si(values, choice, nominal_hz, path, layout)

    t_ns, grid = None, None
    jitter = (0.0, 0.0)
    sample_of_slot = None  # sample index at each slot (-1: a slot the time column skipped)
    if time_data is not None:
        if isinstance(time_data, np.ndarray):
            t_raw = time_data
        elif stamped:
            t_raw = date_time_to_ns(time_data, str(path), lambda k: _line_of(path, layout, k))
        else:
            t_raw = _time_tags(time_data, choice, per_unit, path, layout)
        del time_data
        if t_raw.size >= 2:
            grid = (_quantised_grid(t_raw, path) if rate_hz is None else None) or _time_grid(t_raw, rate_hz, path, layout)
        if grid is not None:
            from chronofuse.io.kernels_time import grid_epochs

            rate_hz = 1e9 / grid.interval_ns
            size = int(grid.slots[-1]) + 1
            if size == values.size:  # no slot skipped: the values are already in place
                sample_of_slot = None
            else:
                placed = np.full(size, np.nan)
                placed[grid.slots] = values
                values = placed
                sample_of_slot = grid.slots
            t_ns = grid_epochs(np.int64(t_raw[0]), grid.start_ns, grid.interval_ns, values.size)
            jitter = (grid.jitter_rms_s, grid.jitter_max_s)
        elif rate_hz is not None and t_raw.size >= 2:
            t_ns = t_raw[0] + np.rint(np.arange(values.size) * (1e9 / rate_hz)).astype(np.int64)
        else:
            t_ns = t_raw
    elif facts.interval_s is not None:
        stated = 1.0 / facts.interval_s
        if rate_hz is None:
            rate_hz = stated
            notes.append(f"sample interval {facts.interval_s:g} s from header line {facts.interval_line}")
        elif abs(rate_hz / stated - 1.0) > _RATE_AGREEMENT:
            warnings.warn(InputWarning(f"{path}: {{rate_hz}} {rate_hz:g} Hz where header line {facts.interval_line} "
                                       f"states a sample interval of {facts.interval_s:g} s ({stated:g} Hz); "
                                       "{rate_hz} used", fields=("rate_hz",)), stacklevel=2)
    if rate_hz is None:
        raise InputError("one-column file: give the sample rate ({rate_hz}, Hz)", str(path), fields=("rate_hz",))

    if choice.kind == "freq" and (choice.unit is None or choice.unit.quantity != "hertz"):
        values = check_frequency(values, path, nominal_hz)
    elif choice.kind == "phase":
        check_phase_steps(values, rate_hz, path, choice)

    n_gaps = int(np.isnan(values).sum())
    if n_gaps == values.size:
        raise InputDataError("every value is missing (NaN)", str(path), layout.first_data_line)
    if n_gaps > max_gap_fraction * values.size:
        start, length = _longest_nan_run(values)
        if sample_of_slot is not None:  # the slots of the samples: the last sample at or before the run
            k = int(np.searchsorted(sample_of_slot, start, side="right")) - 1
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
        kind=choice.kind,
        t_ns=t_ns,
        source=str(path),
        n_gaps=n_gaps,
        column=choice.value_name,
        jitter_rms_s=jitter[0],
        jitter_max_s=jitter[1],
        notes=tuple(notes),
    )


#: A sample is a gross outlier when it differs from both neighbours (the one it has, at an end) by more than
#: this many times the record's median absolute difference between neighbours.
OUTLIER_FACTOR = 1e6


def _warn_outliers(values: np.ndarray, path: Path, layout: Layout) -> None:
    """Warn about gross outliers (:data:`OUTLIER_FACTOR`): a misread or cut-short number (``-2.6950708``
    among values of 1e-10) is analysed as given, but said. A step (a phase jump) differs from one neighbour
    only, and is not warned. The median comes from at most a million differences spread over the record."""
    if values.size < 3:
        return
    d = np.abs(np.diff(values))
    sample = d[:: max(1, d.size // 1_000_000)]
    sample = sample[np.isfinite(sample)]
    scale = float(np.median(sample)) if sample.size else 0.0
    if not scale > 0:
        return
    big = d > OUTLIER_FACTOR * scale
    if not big.any():
        return
    flagged = np.concatenate(([big[0]], big[:-1] & big[1:], [big[-1]]))
    where = np.flatnonzero(flagged)
    if where.size:
        k = int(where[0])
        warnings.warn(InputWarning(
            f"{path}: {where.size} gross outlier{'s' if where.size > 1 else ''} (a value {values[k]:.6g} at line "
            f"{_line_of(path, layout, k)}, differing from its neighbours by more than {OUTLIER_FACTOR:g} times the "
            f"median difference between neighbours, {scale:.3g}): analysed as given; check the file"), stacklevel=3)


def _numeric_time_unit(path: Path, layout: Layout, choice: ColumnChoice, facts=None) -> int | Fraction:
    """ns per unit of a numeric time column: from its name, else from a header's time clause
    (``# time units: min``), else from the magnitude of its first 10 001 values
    (:func:`chronofuse.io.timestamps.infer_time_unit`, which warns), else seconds. A unit word in the name
    that is not understood is warned about, never silently taken for seconds."""
    per_unit = time_ns_per_unit(choice.time_name) if choice.time_name else None
    if per_unit is not None:
        return per_unit
    if facts is not None and facts.time_unit is not None:
        return Fraction(facts.time_unit.scale).limit_denominator(10**15) * 1_000_000_000
    word = re.search(r"[\(\[]\s*([^\)\]]+?)\s*[\)\]]\s*$|_([A-Za-zµμ]+)$", choice.time_name or "")
    if word and (word.group(1) or word.group(2)).lower() not in _TIME_SCALE_WORDS:
        warnings.warn(InputWarning(
            f"{path}: time column {choice.time_name!r}: unit {(word.group(1) or word.group(2))!r} not understood "
            "(s, ms, us, ns, min, h, d, mjd are): its unit is inferred from the values, else read as seconds"),
            stacklevel=3)
    head = [row[choice.time_field] for row in layout.rows if len(row) > choice.time_field]  # the sniffed lines
    try:
        inferred = infer_time_unit(pa.array(head, type=pa.string()), choice.time_name, str(path))
    except (pa.ArrowInvalid, ValueError):
        inferred = None  # text that is no number: the exact conversion names it
    return inferred if inferred is not None else NS_PER_S


#: Words in a time column's name that say its time scale, not its unit.
_TIME_SCALE_WORDS = {"utc", "gps", "tai", "tt", "unix", "local", "gpst", "utc+0", "z"}


def _time_tags(text, choice: ColumnChoice, per_unit, path: Path, layout: Layout) -> np.ndarray:
    """Integer ns of a numeric time column read as text (the layouts the streaming reader does not take)."""
    try:
        t_raw, bad = decimal_text_to_ns(text, per_unit)
    except OverflowError as exc:
        raise InputDataError(f"time column {choice.time_name or '1'!r}: {exc}; name its unit (e.g. t_ms, t_ns)",
                             str(path), layout.first_data_line) from None
    if bad >= 0:
        raise InputDataError(f"cannot read {text[bad].as_py()!r} as a time", str(path), _line_of(path, layout, bad))
    return t_raw


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
        raise InputError("{station} picks a station of a RINEX clock product (.clk); this recording has "
                         "one receiver", str(path), fields=("station",))
    if station is None and len(capture.receivers) > 1:
        warnings.warn(InputWarning(f"{path}: a RINEX clock product of {len(capture.receivers)} stations: the first, "
                                   f"{capture.receivers[0]}, is analysed ({{station}} picks any)", fields=("station",)),
                      stacklevel=2)
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


_TIME_UNIT_SUFFIX = re.compile(r"_(s|ms|us|ns|ps)$")


def _si_name(name: str, kind: str) -> str:
    """A column name with its unit suffix made SI: ``clock_bias_ns`` -> ``clock_bias_s``, ``phase`` ->
    ``phase_s``; a frequency column keeps its name (its values are already fractional frequency)."""
    lowered = name.lower()
    if kind == "phase":
        return _TIME_UNIT_SUFFIX.sub("", lowered) + "_s"
    return lowered


def column_names(path: str | Path) -> list[str] | None:
    """The header names of a record file as :func:`read_record` reads them, or None when it has no header."""
    return sniff(Path(path)).header


def read_side_column(path: str | Path, column: str, size: int) -> np.ndarray:
    """The values of one more column of a text record (a temperature beside the phase), as read, one per
    sample of the record (``size`` of them: a record whose time column skips samples is refused)."""
    path = Path(path)
    from chronofuse.io.record_columns import _field, column_index

    layout = sniff(path)
    field = _field(layout, column_index(layout, path, column))
    values, _, _ = read_columns(path, layout, field, None)
    if values.size != size:
        raise InputDataError(f"column {column!r} has {values.size} values where the record has {size} samples (a "
                             "time column that skips samples): give it on a gap-free record", str(path))
    return values
