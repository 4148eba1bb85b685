"""One receiver clock bias on a regular grid, from a clock-bias CSV or a u-blox UBX capture.

CSV/text files go through :func:`chronofuse.io.records.read_record` (one parser for every text record):
the bias column is ``column`` if given, else the first header name starting with ``clock_bias`` (its unit
suffix ``_s``/``_ns``... scales it), else the only non-time column. UBX captures give ``clkB`` of every
NAV-CLOCK frame (:func:`chronofuse.io.ubx.read_nav_clock`), placed on the ``1/rate`` grid by
:func:`chronofuse.io.grid.regular_grid`.

Missing data are counted, never dropped silently: NaN biases and whole missing intervals of a time column
become NaN epochs, and so do missing UBX solutions; UBX frames that fail their checksum or are cut short add
to ``n_skipped`` too.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.io.formats import sniff_format
from chronofuse.io.grid import regular_grid
from chronofuse.io.records import column_names, read_record
from chronofuse.io.ubx import read_nav_clock
from chronofuse.validation import InputDataError, check_scalar

# A receiver time-tags its solutions on its own clock: u-blox iTOW steps by 999 or 1001 ms now and then.
UBX_TIME_TOLERANCE = 0.05

_BIAS_PREFIX = "clock_bias"


@dataclass(frozen=True)
class ClockBiasInput:
    """One receiver clock bias on a regular grid.

    Attributes
    ----------
    bias_s : ndarray of shape (epochs,)
        Clock bias (s); NaN marks a missing epoch.
    t_s : ndarray of shape (epochs,)
        Time of each epoch on the file's own axis (s): the CSV time column (sample number / rate without
        one), GPS time of week for UBX.
    n_skipped : int
        Missing epochs plus corrupt frames counted while reading.
    source : str
        The file read.
    interval_s : float
        Sampling interval (s): from the time column when the file has one, else ``1 / rate_hz``.
    receiver_ok : ndarray of bool, shape (epochs,), or None
        The receiver's own status per epoch (UBX: a valid fix, :attr:`chronofuse.io.ubx.NavClockRecord.fix_ok`);
        None when the file carries none.
    """

    bias_s: np.ndarray
    t_s: np.ndarray
    n_skipped: int
    source: str = ""
    interval_s: float = float("nan")
    receiver_ok: np.ndarray | None = None

    @property
    def t_ns(self) -> np.ndarray:
        """Epoch times as int64 nanoseconds on the file's axis (``t_s`` rounded to the ns)."""
        return np.round(np.asarray(self.t_s, dtype=np.float64) * 1e9).astype(np.int64)


def bias_column(path: str | Path, column: str | None = None) -> str | None:
    """The clock-bias column of a CSV: ``column`` if given, else the first header name starting with
    ``clock_bias``, else None (:func:`read_record` then takes the only non-time column)."""
    if column is not None:
        return column
    names = column_names(path) or []
    return next((name for name in names if name.lower().startswith(_BIAS_PREFIX)), None)


def read_csv_bias(path: str | Path, rate_hz: float | None, column: str | None = None) -> ClockBiasInput:
    """Clock bias (s) from a CSV/text record via :func:`chronofuse.io.records.read_record` (gaps as NaN).

    The interval comes from the time column when there is one (``rate_hz`` is then not used: a rate
    written as 0.003333 for 300 s need not match it to 1e-6); ``rate_hz`` is needed only without one.
    """
    name = bias_column(path, column)
    try:
        record = read_record(path, kind="phase", rate_hz=None, column=name)
    except InputDataError:
        if rate_hz is None:
            raise
        record = read_record(path, kind="phase", rate_hz=rate_hz, column=name)
    # The file's own time axis (absolute seconds of its time column), or sample times from 0 without one.
    t_s = record.t_ns / 1e9 if record.t_ns is not None else np.arange(record.values.size) / record.rate_hz
    return ClockBiasInput(bias_s=record.values, t_s=t_s, n_skipped=record.n_gaps, source=record.source,
                          interval_s=1.0 / record.rate_hz)


def read_ubx_bias(path: str | Path, rate_hz: float | None = None) -> ClockBiasInput:
    """Clock bias (s) from UBX NAV-CLOCK frames (corrupt frames skipped and counted by the reader).

    Epochs are placed on the ``1/rate_hz`` grid within :data:`UBX_TIME_TOLERANCE` of an interval (the
    receiver tags solutions on its own clock); missing solutions become NaN epochs, counted in ``n_skipped``.
    """
    rec = read_nav_clock(path)
    t = np.asarray(rec.t_s, float)
    if rate_hz is None:
        if t.size < 2:
            raise InputDataError("one NAV-CLOCK solution and no --rate: the interval is unknown", rec.source)
        interval_s = round(float(np.median(np.diff(t))), 3)  # iTOW is in ms
        if interval_s <= 0:
            raise InputDataError("NAV-CLOCK times do not increase: the interval is unknown", rec.source)
    else:
        interval_s = 1.0 / rate_hz
    t_rel_s, bias_s = regular_grid(t, np.asarray(rec.clock_bias_s, float), interval_s,
                                   rec.source, tolerance=UBX_TIME_TOLERANCE)
    t_s = float(rec.itow_ms[0]) / 1000.0 + t_rel_s
    n_missing = int(np.isnan(bias_s).sum())
    ok = None
    if rec.fix_ok is not None:
        _, ok_grid = regular_grid(t, rec.fix_ok.astype(np.float64), interval_s, rec.source, tolerance=UBX_TIME_TOLERANCE)
        ok = ~(ok_grid == 0.0)  # a missing epoch is missing, not a bad status
    return ClockBiasInput(bias_s=bias_s, t_s=t_s, n_skipped=n_missing + int(rec.n_skipped_frames), source=rec.source,
                          interval_s=interval_s, receiver_ok=ok)


def read_clock_bias(path: str | Path, rate_hz: float | None = None, column: str | None = None) -> ClockBiasInput:
    """One receiver clock bias from a CSV/text or UBX file (told apart by :func:`sniff_format`).

    The interval is the file's own (time column, UBX iTOW); ``rate_hz`` serves only a file without times.

    Raises :class:`InputDataError` naming the file for a RINEX file (many satellites, not one clock bias:
    see :func:`chronofuse.integrity.identification.channel_clock_biases`) or unreadable content.
    """
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    kind = sniff_format(path)
    if kind.startswith("rinex"):
        raise InputDataError(f"a {kind} file holds no single receiver clock bias", str(path))
    return read_ubx_bias(path, rate_hz) if kind == "ubx" else read_csv_bias(path, rate_hz, column)
