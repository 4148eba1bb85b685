"""One clock's samples from a field log (:class:`LogSeries`), and the one function every log reader builds
them with (:func:`log_series`). Below the readers (:mod:`~chronofuse.io.linuxptp`, :mod:`~chronofuse.io.chrony`,
:mod:`~chronofuse.io.rtklib_solution`, :mod:`~chronofuse.io.gpsd_json`, :mod:`~chronofuse.io.tsip`) and the
dispatcher above them (:mod:`~chronofuse.io.field_logs`), so that the imports run one way."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError, check_choice

__all__ = ["LogSeries", "log_series", "COLUMN_KINDS"]

#: What a column holds: phase (s), fractional frequency, or another quantity.
COLUMN_KINDS = ("phase", "freq", "other")


@dataclass(frozen=True)
class LogSeries:
    """One clock's samples from a field log.

    Attributes
    ----------
    t_ns : ndarray of int64, shape (N,)
        Time tag of each sample, integer ns on ``time_scale`` (strictly increasing).
    columns : dict of str to ndarray of float64, shape (N,)
        The values, SI units (names end in their unit: ``offset_s``, ``freq``, ``temperature_c``...).
    kinds : dict of str to str
        ``"phase"`` (s), ``"freq"`` (fractional frequency) or ``"other"``, for each column.
    phase : str or None
        The column ``stability`` and ``detect`` take by default (the tool's offset); ``freq`` likewise.
    lines : ndarray of int64, shape (N,)
        1-based file line (or packet number for binary logs) of each sample.
    ok : ndarray of bool, shape (N,), or None
        The tool's own status per sample (servo locked, fix, no alarm), None when it reports none.
    clock : str
        Which clock of the log (``ptp4l``, ``phc2sys CLOCK_REALTIME``, a chrony source, a gpsd device...).
    time_scale : str
        What ``t_ns`` counts: ``"monotonic"`` (linuxptp's CLOCK_MONOTONIC seconds), ``"unix-utc"``,
        ``"gps"`` (ns since 1980-01-06) or ``"unix-system"`` (the host's system clock).
    fmt : str
        The format (:data:`~chronofuse.io.formats.LOG_FORMATS`).
    source : str
        The file.
    notes : tuple of str
        What the reader took from the file and how (units, conventions, lines it passed over).
    events : tuple of (int, str)
        Tool events with their line (servo state changes, port transitions, mode changes).
    """

    t_ns: np.ndarray
    columns: dict
    kinds: dict
    phase: str | None
    lines: np.ndarray
    clock: str
    time_scale: str
    fmt: str
    source: str
    freq: str | None = None
    ok: np.ndarray | None = None
    notes: tuple = ()
    events: tuple = field(default=())

    @property
    def n(self) -> int:
        return int(self.t_ns.size)


def log_series(t_ns, columns: dict, kinds: dict, lines, *, clock: str, time_scale: str, fmt: str, source: str,
               phase: str | None = None, freq: str | None = None, ok=None, notes=(), events=()) -> LogSeries:
    """Build a :class:`LogSeries` (every reader builds its output through this one function), checking that
    the arrays agree in length and the time tags increase (a repeated or backward tag names its line)."""
    try:
        t_ns = np.asarray(t_ns, dtype=np.int64)
    except OverflowError:
        raise InputDataError(f"{clock}: a time tag beyond the range of int64 nanoseconds", source) from None
    lines = np.asarray(lines, dtype=np.int64)
    cols = {name: np.asarray(v, dtype=np.float64) for name, v in columns.items()}
    for name, v in cols.items():
        if v.shape != t_ns.shape:
            raise ValueError(f"column {name} has shape {v.shape}, the time tags {t_ns.shape}")
        check_choice(kinds[name], f"kind of {name}", COLUMN_KINDS)
    if lines.shape != t_ns.shape:
        raise ValueError(f"lines has shape {lines.shape}, the time tags {t_ns.shape}")
    steps = np.diff(t_ns)
    if (steps <= 0).any():
        k = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputDataError(f"{clock}: time tag {t_ns[k] / NS_PER_S:.9f} s does not follow "
                             f"{t_ns[k - 1] / NS_PER_S:.9f} s ({time_scale} scale)", source, int(lines[k]))
    return LogSeries(t_ns=t_ns, columns=cols, kinds=dict(kinds), phase=phase, freq=freq, lines=lines, clock=clock,
                     time_scale=time_scale, fmt=fmt, source=source,
                     ok=None if ok is None else np.asarray(ok, dtype=bool), notes=tuple(notes), events=tuple(events))
