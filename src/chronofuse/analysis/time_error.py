"""Time error split as the ITU-T recommendations split it: constant (cTE) and dynamic (dTE), and the
0.1 Hz measurement filters of G.8273.2 and G.8271.1.

- cTE, the constant time error: ITU-T G.8260 defines it as the mean of the time error over a
  measurement period; G.8273.2 Table 7-3 (its note) estimates it by averaging over 1000 s. Here the
  record is cut into consecutive 1000 s blocks (the whole record when shorter) and the worst block mean
  is the cTE checked against a limit; the mean of the whole record is reported beside it.
- dTE, the dynamic time error: ``TE - mean(TE)``. MTIE and TDEV never see a constant, so the wander
  masks check the same curve either way; max |TE| does see it.
- dTE_L and TE_L: after a first-order low-pass filter of 0.1 Hz bandwidth (G.8273.2 clause 7.1,
  G.8271.1 clause 7.3), ``H(s) = 1 / (1 + s / (2 pi 0.1 Hz))``, discretized by matching its impulse
  response: ``y_k = y_{k-1} + a (x_k - y_{k-1})`` with ``a = 1 - exp(-2 pi 0.1 Hz dt)``, started at the
  first sample and restarted after every gap (a filter cannot run through samples it does not have).
  dTE_H is what the filter takes out, ``TE - TE_L``. The filter only means something when the record
  resolves 0.1 Hz: with samples further apart than 1 s the filtered limits are not evaluated.

Phase ``x_s`` is the time error in seconds, shape (N,), NaN for a missing sample.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from chronofuse.validation import check_array, check_scalar

__all__ = ["FILTER_HZ", "CTE_WINDOW_S", "MAX_FILTER_INTERVAL_S", "TimeErrorSplit", "low_pass", "split_time_error"]

#: Bandwidth of the measurement filter of G.8273.2 and G.8271.1.
FILTER_HZ = 0.1
#: G.8273.2 Table 7-3: cTE estimated by averaging the time error over 1000 s.
CTE_WINDOW_S = 1000.0
#: The 0.1 Hz filter needs at least one sample a second to be a filter at all.
MAX_FILTER_INTERVAL_S = 1.0


def _runs(valid: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of every run of True in ``valid`` (N,)."""
    edges = np.diff(np.concatenate(([0], valid.astype(np.int8), [0])))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def low_pass(x_s: np.ndarray, rate_hz: float, bandwidth_hz: float = FILTER_HZ) -> np.ndarray:
    """First-order low-pass of ``x_s`` (N,) with ``bandwidth_hz`` (module docstring), shape (N,); NaN stays
    NaN and the filter restarts at the first sample after each gap."""
    x = check_array(x_s, "x_s", allow_nan=True)
    check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    check_scalar(bandwidth_hz, "bandwidth_hz", min_val=0, include_min=False)
    a = 1.0 - np.exp(-2.0 * np.pi * bandwidth_hz / rate_hz)
    out = np.full(x.shape, np.nan)
    for start, stop in _runs(~np.isnan(x)):
        seg = x[start:stop]
        out[start:stop] = lfilter([a], [1.0, a - 1.0], seg, zi=[(1.0 - a) * seg[0]])[0]
    return out


@dataclass(frozen=True)
class TimeErrorSplit:
    """A time-error record split into its constant and dynamic parts (seconds).

    Attributes
    ----------
    cte_s : float
        Mean time error of the whole record.
    cte_worst_s : float
        The 1000 s block mean of largest magnitude (the record's mean when shorter than 1000 s).
    max_abs_te_s : float
        Largest |TE|, constant part included.
    max_abs_dte_s : float
        Largest |TE - cte_s|.
    dte_pp_s : float
        Peak-to-peak time error (the record's MTIE over its whole length).
    """

    cte_s: float
    cte_worst_s: float
    max_abs_te_s: float
    max_abs_dte_s: float
    dte_pp_s: float

    def to_dict(self) -> dict:
        """JSON-ready dict."""
        return {"cte": self.cte_s, "cte_worst_1000s": self.cte_worst_s, "max_abs_te": self.max_abs_te_s,
                "max_abs_dte": self.max_abs_dte_s, "dte_peak_to_peak": self.dte_pp_s}


def split_time_error(x_s: np.ndarray, rate_hz: float, window_s: float = CTE_WINDOW_S) -> TimeErrorSplit:
    """cTE (record mean and worst ``window_s`` block mean), max |TE|, max |dTE| and peak-to-peak of ``x_s``."""
    x = check_array(x_s, "x_s", allow_nan=True)
    check_scalar(rate_hz, "rate_hz", min_val=0, include_min=False)
    if not np.isfinite(x).any():
        raise ValueError("x_s has no valid sample")
    mean = float(np.nanmean(x))
    per_block = max(int(round(window_s * rate_hz)), 1)
    blocks = x.size // per_block
    if blocks >= 1:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a block of only NaN has no mean
            means = np.nanmean(x[: blocks * per_block].reshape(blocks, per_block), axis=1)
        means = means[np.isfinite(means)]
        worst = float(means[np.argmax(np.abs(means))]) if means.size else mean
    else:
        worst = mean
    return TimeErrorSplit(mean, worst, float(np.nanmax(np.abs(x))), float(np.nanmax(np.abs(x - mean))),
                          float(np.nanmax(x) - np.nanmin(x)))
