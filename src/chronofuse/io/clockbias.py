"""One receiver clock bias on a regular grid, as an :class:`~chronofuse.record.EpochRecord`, from a clock-bias
CSV, a receiver recording (UBX, NMEA + UBX) or one station of a RINEX clock product.

CSV/text files go through :func:`chronofuse.io.records.read_record` (one parser for every text record):
the bias column is ``column`` if given, else the first header name starting with ``clock_bias`` (its unit
suffix ``_s``/``_ns``... scales it), else the only non-time column; ``t_ns`` is the time column in exact
integer nanoseconds on the file's own axis (``time_scale == "file"``). Receiver recordings give ``clkB`` of
every NAV-CLOCK message through the capture reader every other command uses
(:func:`chronofuse.io.capture_series.read_clock_series`), on GPS time.

The record's column is ``clock_bias_s`` (s); a recording adds ``clock_drift_s_per_s``, ``time_acc_s`` and
``fix_mode``, and ``valid`` is False where the receiver reported no fix. Missing data are counted, never
dropped silently: NaN biases and missing slots of the grid are NaN epochs (``info["n_gaps"]``), and UBX
frames that fail their checksum, are cut short or that pyubx2 refuses are ``info["n_damaged"]``;
:func:`n_skipped` is their sum.
"""

from __future__ import annotations

from pathlib import Path

from chronofuse.io.capture_series import read_clock_series
from chronofuse.io.formats import CAPTURE_FORMATS, LOG_FORMATS, sniff_format
from chronofuse.io.records import column_names, epoch_record, read_record
from chronofuse.record import EpochRecord
from chronofuse.validation import InputDataError, check_scalar

__all__ = ["bias_column", "n_skipped", "read_capture_bias", "read_clock_bias", "read_csv_bias"]

_BIAS_PREFIX = "clock_bias"


def n_skipped(record: EpochRecord) -> int:
    """Missing epochs (gaps and NaN biases) plus damaged frames counted while reading ``record``."""
    return int(record.info.get("n_gaps", 0)) + int(record.info.get("n_damaged", 0))


def bias_column(path: str | Path, column: str | None = None) -> str | None:
    """The clock-bias column of a CSV: ``column`` if given, else the first header name starting with
    ``clock_bias``, else None (:func:`read_record` then takes the only non-time column)."""
    if column is not None:
        return column
    names = column_names(path) or []
    return next((name for name in names if name.lower().startswith(_BIAS_PREFIX)), None)


def read_csv_bias(path: str | Path, rate_hz: float | None, column: str | None = None) -> EpochRecord:
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
    return epoch_record(record, "clock_bias_s")


def read_capture_bias(path: str | Path, rate_hz: float | None = None, station: str | None = None) -> EpochRecord:
    """Clock bias (s) of a receiver recording (UBX NAV-CLOCK, alone or mixed with NMEA; or a station of a
    RINEX clock product), through the one capture path:
    :func:`chronofuse.io.capture_series.read_clock_series` over :func:`chronofuse.io.inspect.read_capture`."""
    return read_clock_series(path, rate_hz, station)


def read_clock_bias(path: str | Path, rate_hz: float | None = None, column: str | None = None,
                    clock: str | None = None) -> EpochRecord:
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
