"""The field's own logs as clock series: one dispatcher from a log file to the records the commands analyse.

A log reader (one module per format: :mod:`~chronofuse.io.linuxptp`, :mod:`~chronofuse.io.chrony`,
:mod:`~chronofuse.io.rtklib_solution`, :mod:`~chronofuse.io.gpsd_json`, :mod:`~chronofuse.io.tsip`) gives
a list of :class:`LogSeries`, one per clock the log holds (a linuxptp clock, a chrony source, a gpsd
device, ...): time tags as integer ns on the log's own time scale,
named columns in SI units, the kind of each column (phase in s, fractional frequency, or other), the 1-based
file line of every sample, and the tool's own status per sample where it reports one.

Two functions turn a series into what the commands read, and they are the only place that builds those
records from a log: :func:`series_record` (a :class:`~chronofuse.io.records.ClockRecord` on a regular
grid, for ``stability`` and the GNSSDO's ``--reference``) and :func:`series_clock_bias` (an
:class:`~chronofuse.record.EpochRecord` of the clock bias, for ``detect``). A tool's samples come on its own
schedule (ptp4l once per sync interval, chrony at each clock update): each sample is placed on the grid
of the median interval when it lies within a quarter interval of its slot, empty slots become gaps (NaN),
and a sample further off is refused naming its line. A log whose interval changes (a new poll interval)
is refused the same way; a rate given with ``rate_hz`` sets the grid instead of the median step.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from chronofuse.io.formats import LOG_FORMATS, sniff_format
from chronofuse.io.grid import grid_slots, place_on_grid
from chronofuse.io.log_series import LogSeries, log_series
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError, InputError, InputWarning

__all__ = ["LogSeries", "read_log", "log_series", "pick_series", "series_record", "series_clock_bias",
           "log_record", "log_clock_bias", "summarize_log", "LOG_FORMATS"]

#: A sample may sit this fraction of the interval off its grid slot (the tools stamp on a loaded host).
SLOT_TOLERANCE = 0.25


def _reader(fmt: str):
    if fmt == "linuxptp":
        from chronofuse.io.linuxptp import read_linuxptp as read
    elif fmt == "chrony":
        from chronofuse.io.chrony import read_chrony as read
    elif fmt in ("rtklib-pos", "rtklib-stat"):
        from chronofuse.io.rtklib_solution import read_rtklib as read
    elif fmt == "gpsd-json":
        from chronofuse.io.gpsd_json import read_gpsd_json as read
    elif fmt == "tsip":
        from chronofuse.io.tsip import read_tsip as read
    else:
        raise ValueError(f"fmt == {fmt!r}, must be one of {list(LOG_FORMATS)}")
    return read


def read_log(path: str | Path, fmt: str | None = None) -> list[LogSeries]:
    """Every clock series of a field log (the format sniffed from its content unless ``fmt`` is given).

    Raises :class:`InputDataError` naming the file for a file that is no field log, or one that holds
    no sample at all.
    """
    path = Path(path)
    fmt = fmt or sniff_format(path)
    if fmt not in LOG_FORMATS:
        raise InputDataError(f"not a field log this reader knows (sniffed as {fmt}); logs read: "
                             f"{', '.join(LOG_FORMATS)}", str(path))
    series = [s for s in _reader(fmt)(path) if s.n]
    if not series:
        raise InputDataError(f"a {fmt} log without a single clock sample", str(path))
    return series


def pick_series(series: list[LogSeries], clock: str | None, source: str) -> LogSeries:
    """The series of ``clock`` (its full name, or a unique part of it); without ``clock`` the first, with a
    warning naming the others when there are several."""
    if clock is None:
        if len(series) > 1:
            warnings.warn(InputWarning(f"{source}: {len(series)} clocks in this log "
                                       f"({', '.join(s.clock for s in series)}): the first, {series[0].clock!r}, "
                                       "is read ({clock} picks another)", fields=("clock",)), stacklevel=3)
        return series[0]
    exact = [s for s in series if s.clock == clock]
    if exact:
        return exact[0]
    partial = [s for s in series if clock in s.clock]
    if len(partial) == 1:
        return partial[0]
    names = ", ".join(repr(s.clock) for s in series)
    raise InputError(f"{{clock}} {clock!r} {'matches several' if partial else 'is none'} of this log's clocks: "
                     f"{names}", source, fields=("clock",))


def _column(s: LogSeries, column: str | None, kind: str | None) -> tuple[str, str]:
    """(column name, kind): ``column`` if given, else the series' phase column (or its frequency one for
    ``kind="freq"``)."""
    if column is None:
        column = s.freq if kind == "freq" else s.phase
        if column is None:
            raise InputDataError(f"{s.clock}: this log has no {'frequency' if kind == 'freq' else 'offset'} series "
                                 f"(columns: {', '.join(s.columns)})", s.source)
    if column not in s.columns:
        raise InputError(f"{{column}} {column!r}: not a column of {s.clock} (columns: {', '.join(s.columns)})",
                         s.source, fields=("column",))
    have = s.kinds[column]
    if have == "other" and kind is None:
        raise InputError(f"column {column!r} is neither phase nor frequency: give {{kind}} phase or {{kind}} freq "
                         "to analyse it anyway", s.source, fields=("kind",))
    if kind is not None and have != "other" and kind != have:
        raise InputDataError(f"column {column!r} is {have}, not {kind}", s.source)
    return column, kind or have


def _grid(s: LogSeries, rate_hz: float | None) -> tuple[np.ndarray, float, float, float]:
    """(slots (N,), interval ns, jitter rms s, jitter max s) of the series' samples on a regular grid."""
    if s.n < 2 and rate_hz is None:
        raise InputError(f"{s.clock}: one sample and no {{rate_hz}}: the interval is unknown", s.source,
                         fields=("rate_hz",))
    offsets = (s.t_ns - s.t_ns[0]).astype(np.float64)
    if rate_hz is not None:
        interval = NS_PER_S / rate_hz
    else:
        steps = np.diff(offsets)
        interval = float(np.median(steps))
        interval = _snap(interval, steps)
    slots, bad = grid_slots(offsets, interval, SLOT_TOLERANCE)
    if bad >= 0:
        step = (s.t_ns[bad] - s.t_ns[bad - 1]) / NS_PER_S
        steps = np.diff(s.t_ns) / NS_PER_S
        raise InputDataError(f"{s.clock}: time step {step:.6g} s is not a whole number of {interval / NS_PER_S:.6g} s "
                             f"intervals (tolerance {SLOT_TOLERANCE} of an interval); this log's steps range from "
                             f"{steps.min():.6g} s to {steps.max():.6g} s: a record needs regular samples and a log is "
                             "not resampled ({rate_hz} sets the interval when it changed)", s.source, int(s.lines[bad]),
                             fields=("rate_hz",))
    resid = offsets - slots * interval
    resid -= resid.mean()
    return slots, interval, float(np.sqrt(np.mean(resid**2))) / NS_PER_S, float(np.abs(resid).max()) / NS_PER_S


def _snap(interval_ns: float, steps: np.ndarray) -> float:
    """The median step, or the mean step over the steps near it (the tools' ms time tags make a 62.5 ms
    interval show as 62 or 63 ms); rounded to 6 significant digits when that changes it by under 1e-4."""
    near = steps[np.abs(steps - interval_ns) <= SLOT_TOLERANCE * interval_ns]
    mean = float(near.mean()) if near.size else interval_ns
    rounded = float(f"{mean:.6g}")
    return rounded if abs(rounded - mean) < 1e-4 * mean else mean


def series_record(s: LogSeries, kind: str | None = None, column: str | None = None, rate_hz: float | None = None):
    """The :class:`~chronofuse.io.records.ClockRecord` of one series: ``column`` (default: its phase column, or
    its frequency column for ``kind="freq"``) on the regular grid of the series' interval (``rate_hz`` sets
    it), gaps as NaN; ``t_ns`` holds the grid epochs on the log's time scale. A sample the tool marks as not
    locked/fixed stays in the record (it is the tool's measurement) and is counted in the notes."""
    from chronofuse.io.clock_record import ClockRecord

    name, kind = _column(s, column, kind)
    slots, interval, rms, peak = _grid(s, rate_hz)
    values = place_on_grid(slots, s.columns[name])
    n_gaps = int(np.isnan(values).sum())
    if n_gaps == values.size:
        raise InputDataError(f"{s.clock}: every {name} value is missing", s.source)
    notes = list(s.notes)
    if s.ok is not None and not s.ok.all():
        notes.append(f"{int((~s.ok).sum())} of {s.n} samples are marked by the tool as not locked / no fix "
                     f"(first at line {int(s.lines[np.flatnonzero(~s.ok)[0]])})")
    t0 = int(s.t_ns[0])
    t_ns = t0 + np.round(np.arange(values.size) * interval).astype(np.int64)
    return ClockRecord(values=values, rate_hz=NS_PER_S / interval, kind=kind, t_ns=t_ns, source=s.source,
                       n_gaps=n_gaps, column=f"{s.clock}: {name}", jitter_rms_s=rms, jitter_max_s=peak,
                       notes=tuple(notes))


def series_clock_bias(s: LogSeries, column: str | None = None, rate_hz: float | None = None):
    """The :class:`~chronofuse.record.EpochRecord` of one series that ``detect`` reads: the phase column as
    ``clock_bias_s`` (s) on the series' grid, ``t_ns`` the grid's epochs on the log's time scale (``gps`` for
    GPS-time logs, ``file`` for the others), ``valid`` the tool's own status (False where the servo was not
    locked or the receiver had no fix; a gap says nothing bad), provenance the log line (TSIP: the packet
    index) of each sample, -1 in a gap."""
    from chronofuse.record import EpochRecord

    name, kind = _column(s, column, "phase" if column is None else None)
    if kind != "phase":
        raise InputDataError(f"column {name!r} is {kind}: detect reads a clock offset (phase, s)", s.source)
    slots, interval, rms, peak = _grid(s, rate_hz)
    bias = place_on_grid(slots, s.columns[name])
    valid = np.ones(bias.size, dtype=bool)
    if s.ok is not None:
        valid[slots] = s.ok
    position = np.full(bias.size, -1, dtype=np.int64)
    binary = s.fmt == "tsip"
    position[slots] = s.lines - 1 if binary else s.lines
    interval_ns = int(round(interval))
    t_ns = s.t_ns[0] + np.round(np.arange(bias.size) * interval).astype(np.int64)
    return EpochRecord.from_arrays(t_ns, {"clock_bias_s": bias}, {"clock_bias_s": "s"}, source=s.source,
                                   valid=valid, interval_ns=interval_ns,
                                   time_scale="gps" if s.time_scale == "gps" else "file", position=position,
                                   position_unit="index" if binary else "line",
                                   info={"n_gaps": int(np.isnan(bias).sum()), "jitter_rms_s": rms,
                                         "jitter_max_s": peak, "clock": s.clock})


def log_record(path, *, kind: str | None = None, rate_hz: float | None = None, column: str | None = None,
               clock: str | None = None, fmt: str | None = None):
    """:func:`series_record` of the clock ``clock`` (the first without it) of the log at ``path``."""
    s = pick_series(read_log(path, fmt), clock, str(path))
    return series_record(s, kind=kind, column=column, rate_hz=rate_hz)


def log_clock_bias(path, *, rate_hz: float | None = None, column: str | None = None, clock: str | None = None,
                   fmt: str | None = None):
    """:func:`series_clock_bias` of the clock ``clock`` (the first without it) of the log at ``path``."""
    s = pick_series(read_log(path, fmt), clock, str(path))
    return series_clock_bias(s, column=column, rate_hz=rate_hz)


def summarize_log(series: list[LogSeries]) -> dict:
    """What ``chronofuse inspect`` prints for a field log: per clock the samples, span, median interval, columns
    with their kinds, samples the tool marked not ok, and the events."""
    clocks = []
    for s in series:
        steps = np.diff(s.t_ns)
        clocks.append({
            "clock": s.clock, "samples": s.n, "time_scale": s.time_scale,
            "start_s": int(s.t_ns[0]) / NS_PER_S, "end_s": int(s.t_ns[-1]) / NS_PER_S,
            "span_s": (int(s.t_ns[-1]) - int(s.t_ns[0])) / NS_PER_S,
            "interval_s": float(np.median(steps)) / NS_PER_S if steps.size else None,
            "columns": {name: s.kinds[name] for name in s.columns},
            "phase": s.phase, "freq": s.freq,
            "not_ok": None if s.ok is None else int((~s.ok).sum()),
            "first_line": int(s.lines[0]), "last_line": int(s.lines[-1]),
            "events": [{"line": line, "event": text} for line, text in s.events],
            "notes": list(s.notes)})
    return {"file": series[0].source, "format": series[0].fmt, "clocks": clocks}
