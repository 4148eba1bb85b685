"""Conversions between phase and fractional-frequency records, and gap handling."""

from __future__ import annotations

import numpy as np

from chronofuse.validation import InputError, check_array, check_choice, check_scalar


#: How the mean frequency of a frequency record enters the phase it is integrated to: ``"keep"`` (the
#: phase the frequency implies: a frequency offset is a time error that grows, and TIE rms and MTIE see it)
#: or ``"remove"`` (integrate ``y - mean(y)``, as allantools' ``frequency2phase`` does: TIE rms and MTIE of
#: the wander alone). The Allan, Hadamard and total families and Theo1 are the same either way.
FREQUENCY_MEANS = ("keep", "remove")


def frequency_to_phase(y: np.ndarray, rate_hz: float, mean: str = "keep") -> np.ndarray:
    """Integrate fractional frequency ``y`` (N,) into phase ``x`` (N+1,) in seconds, ``x[0] = 0``.

    ``x[i+1] = x[i] + y[i] / rate_hz`` (NIST SP 1065 eq. 4 inverted); with ``mean="remove"`` the record's
    mean frequency is subtracted first (:data:`FREQUENCY_MEANS`). A NaN frequency sample is integrated as
    the record's mean frequency and the phase at its end is marked NaN. A phase difference across a
    missing frequency sample is unknown, however far its ends are from the gap, so statistics of such a
    record need ``gap_rule="span"`` (a term is skipped when its span holds a missing sample; the CLI sets
    it for frequency input), and then no result depends on the value put in the gap; MTIE windows use the
    samples present (``"window"``), and the total family and Theo1 interpolate (``"fill"``).
    """
    y = check_array(y, "y", allow_nan=True)
    check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    check_choice(mean, "mean", FREQUENCY_MEANS)
    tau0 = 1.0 / rate_hz
    gaps = np.isnan(y)
    average = np.nanmean(y) if (~gaps).any() else 0.0
    if mean == "remove":
        y = y - average
        average = 0.0
    filled = np.where(gaps, average, y)
    x = np.concatenate(([0.0], np.cumsum(filled) * tau0))
    # A missing frequency sample makes the phase at its end unknown.
    x[1:][gaps] = np.nan
    return x


def phase_to_frequency(x: np.ndarray, rate_hz: float) -> np.ndarray:
    """First difference of phase over the sample interval: ``y[i] = (x[i+1] - x[i]) * rate_hz``."""
    x = check_array(x, "x", allow_nan=True)
    check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    return np.diff(x) * rate_hz


def fill_gaps(x: np.ndarray) -> tuple[np.ndarray, int]:
    """Linearly interpolate NaN runs inside ``x``; leading/trailing NaN are trimmed.

    Returns the filled copy and the number of samples filled (interior) plus trimmed (ends).
    """
    x = np.asarray(x, dtype=float)
    nan = np.isnan(x)
    if not nan.any():
        return x, 0
    valid = np.flatnonzero(~nan)
    if valid.size == 0:
        raise InputError("x contains only NaN")
    trimmed = x[valid[0] : valid[-1] + 1]
    nan_t = np.isnan(trimmed)
    idx = np.arange(trimmed.size)
    out = trimmed.copy()
    out[nan_t] = np.interp(idx[nan_t], idx[~nan_t], trimmed[~nan_t])
    return out, int(nan.sum())
