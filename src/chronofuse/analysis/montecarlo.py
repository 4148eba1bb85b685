"""Confidence intervals of Monte Carlo figures: rms over trials, and ratios of two rms on the same trials.

Trials are independent; the seconds inside a trial are not (a servo's error is correlated over its loop
time constant), so every interval is built from one number per trial, its mean square ``m_i`` over the
trial's window. The rms is ``sqrt(mean m_i)``; its interval is Student's t interval of ``mean m_i``
(``n - 1`` degrees of freedom; the central limit theorem over trials) mapped through the square root,
clipped at zero. A ratio of two rms on the same trials, ``sqrt(mean a_i / mean b_i)``, gets the delta
method on its logarithm with the paired influence ``a_i / mean a - b_i / mean b`` (A. C. Davison and D. V.
Hinkley, *Bootstrap Methods and their Application*, 1997, sec. 2.7: the nonparametric delta method).
One trial gives no interval (NaN bounds).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from chronofuse.validation import check_array, check_scalar

__all__ = ["rms_ci", "ratio_ci", "mean_square_per_trial"]


def mean_square_per_trial(x, window=None) -> np.ndarray:
    """``m_i``: the mean of ``x_i^2`` over each row's True ``window`` entries (trials,); NaN for an empty window."""
    a = check_array(x, "x", ndim=2, allow_nan=True)
    w = np.isfinite(a) if window is None else np.broadcast_to(np.asarray(window, dtype=bool), a.shape) & np.isfinite(a)
    count = w.sum(axis=1)
    total = np.where(w, a, 0.0)
    total = (total * total).sum(axis=1)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _t(level: float, n: int) -> float:
    return float(stats.t.ppf(0.5 + level / 2.0, n - 1))


def rms_ci(mean_squares, level: float = 0.95) -> tuple[float, float, float]:
    """``(rms, low, high)`` of ``sqrt(mean m_i)`` over the finite ``m_i`` (module docstring)."""
    check_scalar(level, "level", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
    m = np.asarray(mean_squares, dtype=float)
    m = m[np.isfinite(m)]
    if m.size == 0:
        return math.nan, math.nan, math.nan
    mean = float(m.mean())
    if m.size < 2:
        return math.sqrt(mean), math.nan, math.nan
    half = _t(level, m.size) * float(m.std(ddof=1)) / math.sqrt(m.size)
    return math.sqrt(mean), math.sqrt(max(mean - half, 0.0)), math.sqrt(mean + half)


def ratio_ci(mean_squares_a, mean_squares_b, level: float = 0.95) -> tuple[float, float, float]:
    """``(ratio, low, high)`` of ``sqrt(mean a_i / mean b_i)`` over trials where both are finite."""
    check_scalar(level, "level", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
    a = np.asarray(mean_squares_a, dtype=float)
    b = np.asarray(mean_squares_b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"mean_squares_a has shape {a.shape}, mean_squares_b {b.shape}: must be the same trials")
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    if a.size == 0 or b.mean() <= 0.0:
        return math.nan, math.nan, math.nan
    ratio = math.sqrt(a.mean() / b.mean())
    if a.size < 2 or a.mean() <= 0.0:
        return ratio, math.nan, math.nan
    influence = a / a.mean() - b / b.mean()
    half = 0.5 * _t(level, a.size) * float(influence.std(ddof=1)) / math.sqrt(a.size)
    return ratio, ratio * math.exp(-half), ratio * math.exp(half)
