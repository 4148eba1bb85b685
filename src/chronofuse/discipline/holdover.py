"""Holdover: the time error a GPSDO accumulates without a reference, and the physical limit.

In holdover the Kalman servos keep steering with their last frequency and drift estimates (the update
is skipped, the prediction runs on), so the error after a horizon ``h`` grows from three sources: the
frequency error at entry (``~ h``), the drift error (``~ h^2 / 2``) and the oscillator's own noise
after entry. :func:`holdover_error` measures ``x(t0 + h) - x(t0)`` on a run.

The physical limit is the clairvoyant predictor: it knows the true drift ``D`` and the oscillator's
true, noise-free phase history up to entry, and extrapolates ``x(t0) + y_m h + D h^2 / 2`` with
``y_m = (x(t0) - x(t0 - m)) / m + D m / 2`` the true mean frequency over the last ``m`` seconds (the
``D m / 2`` term carries it from the window's middle to ``t0``), ``m`` chosen per horizon to minimise
the error over the trials. What remains is the noise the oscillator makes after ``t0`` (and the part
of its frequency no window of its own past can predict): no controller fed by any reference can do
better with this oscillator. For white FM plus random-walk FM alone its rms is the two-state model's
prediction error; flicker FM adds the part that an m-window average cannot anticipate.
"""

from __future__ import annotations

import numpy as np

from chronofuse.validation import check_array, check_scalar

__all__ = ["holdover_error", "clairvoyant_holdover_error", "HOLDOVER_HORIZONS_S"]

#: The horizons every report gives: 1 h, 4 h, 24 h.
HOLDOVER_HORIZONS_S = np.array([3600.0, 4 * 3600.0, 24 * 3600.0])


def _indices(start_index: int, horizons_s, interval_s: float, steps: int) -> np.ndarray:
    h = check_array(horizons_s, "horizons_s", ndim=1)
    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    idx = start_index + np.rint(h / interval_s).astype(np.int64)
    if start_index < 0 or np.any(idx >= steps):
        raise ValueError(f"horizons_s == {h.tolist()} from index {start_index} run past the record ({steps} steps)")
    return idx


def holdover_error(phase_s, start_index: int, horizons_s, interval_s: float = 1.0) -> np.ndarray:
    """``x(t0 + h) - x(t0)`` per trial and horizon, shape (trials, horizons); ``phase_s`` (trials, steps)."""
    x = check_array(phase_s, "phase_s", ndim=2)
    idx = _indices(start_index, horizons_s, interval_s, x.shape[1])
    return x[:, idx] - x[:, [start_index]]


def clairvoyant_holdover_error(free_phase_s, start_index: int, horizons_s, drift_per_s: float,
                               interval_s: float = 1.0, windows_s=None) -> tuple[np.ndarray, np.ndarray]:
    """The clairvoyant predictor's error (trials, horizons) and the window chosen per horizon (s).

    ``free_phase_s`` (trials, steps): the oscillator's true free-running phase (any control added
    before ``t0`` is a known input and changes nothing here); ``windows_s``: the candidate ``m``
    (default: octaves from one interval to the whole history).
    """
    x = check_array(free_phase_s, "free_phase_s", ndim=2)
    idx = _indices(start_index, horizons_s, interval_s, x.shape[1])
    h = (idx - start_index) * interval_s
    if windows_s is None:
        windows = 2 ** np.arange(int(np.log2(max(start_index, 1))) + 1)
    else:
        windows = np.rint(check_array(windows_s, "windows_s", ndim=1) / interval_s).astype(np.int64)
    windows = windows[(windows >= 1) & (windows <= start_index)]
    if windows.size == 0:
        raise ValueError(f"start_index == {start_index}: no history to estimate a frequency from")
    x0 = x[:, start_index]
    best = np.full((x.shape[0], h.size), np.nan)
    best_rms = np.full(h.size, np.inf)
    chosen = np.zeros(h.size)
    for m in windows:
        y_m = (x0 - x[:, start_index - m]) / (m * interval_s) + drift_per_s * m * interval_s / 2.0
        pred = x0[:, None] + y_m[:, None] * h[None, :] + 0.5 * drift_per_s * h[None, :] ** 2
        err = x[:, idx] - pred
        rms = np.sqrt(np.mean(err**2, axis=0))
        better = rms < best_rms
        best[:, better] = err[:, better]
        best_rms = np.where(better, rms, best_rms)
        chosen = np.where(better, m * interval_s, chosen)
    return best, chosen
