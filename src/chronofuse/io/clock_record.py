"""The phase or fractional-frequency record ``stability`` and the GNSSDO's reference read
(:class:`ClockRecord`), apart from its readers (:func:`chronofuse.io.records.read_record` for text records
and receiver recordings, :func:`chronofuse.io.field_logs.series_record` for the field's logs), so that both
build it without importing each other."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.timescale import NS_PER_S

__all__ = ["ClockRecord"]


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
    notes : tuple of str
        What the reader took from the file rather than from the caller (the values' unit from a header
        line, the sample interval from a header block, the lines of a header block it skipped).
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
    notes: tuple[str, ...] = ()

    @property
    def t_s(self) -> np.ndarray | None:
        """Seconds since the first sample (a duration, float64), shape (N,), or None without a time column."""
        if self.t_ns is None:
            return None
        return (self.t_ns - self.t_ns[0]) / NS_PER_S
