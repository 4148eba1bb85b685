"""One receiver clock bias on a regular grid, from a clock-bias CSV or a receiver recording (UBX, NMEA + UBX).

CSV/text files go through :func:`chronofuse.io.records.read_record` (one parser for every text record):
the bias column is ``column`` if given, else the first header name starting with ``clock_bias`` (its unit
suffix ``_s``/``_ns``... scales it), else the only non-time column. Receiver recordings give ``clkB`` of
every NAV-CLOCK message through the capture reader every other command uses
(:func:`chronofuse.io.capture_series.read_clock_series`), on the recording's own interval.

Missing data are counted, never dropped silently: NaN biases and whole missing intervals of a time column
become NaN epochs, and so do missing UBX solutions; UBX frames that fail their checksum, are cut short or
that pyubx2 refuses add to ``n_skipped`` too.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from chronofuse.io.capture_series import read_clock_series
from chronofuse.io.formats import CAPTURE_FORMATS, LOG_FORMATS, sniff_format
from chronofuse.io.records import column_names, read_record
from chronofuse.timescale import NS_PER_S, NS_PER_WEEK
from chronofuse.validation import InputDataError, check_scalar

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
        The receiver's own status per epoch (a recording: False where it reported no fix,
        :attr:`chronofuse.io.capture_series.ClockBiasSeries.receiver_ok`); None when the file carries none.
    time_acc_s : ndarray of float64, shape (epochs,), or None
        The receiver's time accuracy estimate per epoch (a recording's NAV-CLOCK ``tAcc``, s; NaN where not
        reported); None when the file carries none.
    """

    bias_s: np.ndarray
    t_s: np.ndarray
    n_skipped: int
    source: str = ""
    interval_s: float = float("nan")
    receiver_ok: np.ndarray | None = None
    time_acc_s: np.ndarray | None = None

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


def read_capture_bias(path: str | Path, rate_hz: float | None = None) -> ClockBiasInput:
    """Clock bias (s) of a receiver recording (UBX NAV-CLOCK, alone or mixed with NMEA), through the one
    capture path: :func:`chronofuse.io.capture_series.read_clock_series` over
    :func:`chronofuse.io.inspect.read_capture`.

    Epochs are placed on the ``1/rate_hz`` grid (the recording's own interval without it) within
    :data:`~chronofuse.io.capture_series.TIME_TOLERANCE` of an interval; missing solutions become NaN epochs,
    counted in ``n_skipped`` with the damaged frames. ``t_s`` is GPS time of week of the first epoch plus
    the grid offsets (continuous over a week rollover).
    """
    series = read_clock_series(path, rate_hz)
    tow0_ns = int(series.gps_ns[0]) % NS_PER_WEEK
    t_s = (tow0_ns + (series.gps_ns - series.gps_ns[0])) / NS_PER_S
    return ClockBiasInput(bias_s=series.clock_bias_s, t_s=t_s, n_skipped=series.n_missing + series.n_damaged,
                          source=series.source, interval_s=series.interval_s, receiver_ok=series.receiver_ok,
                          time_acc_s=series.time_acc_s)


def read_clock_bias(path: str | Path, rate_hz: float | None = None, column: str | None = None,
                    clock: str | None = None) -> ClockBiasInput:
    """One receiver clock bias from a CSV/text file, a receiver recording (UBX alone or with NMEA) or a field
    log's clock offset (``clock`` picks it: :func:`chronofuse.io.field_logs.log_clock_bias`); told apart by
    :func:`sniff_format`.

    The interval is the file's own (time column, UBX iTOW); ``rate_hz`` serves a CSV without times and sets
    a recording's grid interval.

    Raises :class:`InputDataError` naming the file for a RINEX file (many satellites, not one clock bias:
    see :func:`chronofuse.integrity.identification.channel_clock_biases`) or unreadable content.
    """
    if rate_hz is not None:
        check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    kind = sniff_format(path)
    if kind in LOG_FORMATS:  # a field log: the offset of one of its clocks (``clock``; the first without it)
        from chronofuse.io.field_logs import log_clock_bias

        return log_clock_bias(path, rate_hz=rate_hz, column=column, clock=clock, fmt=kind)
    if clock is not None:
        raise InputDataError("a clock is picked in a field log (linuxptp, chrony, RTKLIB, gpsd, TSIP), not here",
                             str(path))
    if kind.startswith("rinex"):
        raise InputDataError(f"a {kind} file holds no single receiver clock bias", str(path))
    return read_capture_bias(path, rate_hz) if kind in CAPTURE_FORMATS else read_csv_bias(path, rate_hz, column)
