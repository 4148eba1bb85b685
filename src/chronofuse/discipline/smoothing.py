"""Offline fixed-interval smoothing of a recorded disciplined run (the GNSSDO paper eqs. (3-3)-(3-7)).

A recorded run holds the measured offsets ``z_k`` and what the servo did (corrections ``u_k``, phase
steps ``s_k``). Those are known inputs, so the offsets the free-running oscillator would have given are
``z_k - c_k`` with ``c_k = sum_{j<k} (s_j + dt u_j)``; the Kalman filter of the servo's own model runs
forward over them (``estimation.filter.KalmanFilter``) and the one Rauch-Tung-Striebel smoother
(``estimation.rts.rts_smooth``) backward; adding ``c_k`` back gives the filtered and the smoothed
estimates of the disciplined 1PPS's time error. The smoother uses the measurements after ``k`` too and
so removes the filter's lag (the source paper's 40 ns -> 10 ns claim; our measurement is in docs/gnssdo).
The source paper's three-state model [t, f, phi] carries an unobservable phase state; this uses the servo's
[phase, frequency, drift] (+ Gauss-Markov) model, which is observable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.discipline.kalman import KalmanServo
from chronofuse.discipline.loop import LoopRun
from chronofuse.discipline.servo import freeze
from chronofuse.estimation.filter import KalmanFilter
from chronofuse.estimation.rts import rts_smooth

__all__ = ["SmoothedRun", "smooth_run", "control_phase_s"]


@dataclass(frozen=True)
class SmoothedRun:
    """Filtered and smoothed estimates of the disciplined time error (trials, steps) and the smoother's
    one-sigma (s), read-only."""

    filtered_s: np.ndarray
    smoothed_s: np.ndarray
    smoothed_sigma_s: np.ndarray

    def __post_init__(self):
        freeze(self)


def control_phase_s(loop: LoopRun) -> np.ndarray:
    """``c_k = sum_{j<k} (s_j + dt u_j)``: the phase the servo added before second ``k``, (trials, steps)."""
    inc = loop.phase_step_s + loop.interval_s * loop.freq_adj
    c = np.zeros(inc.shape)
    np.cumsum(inc[:, :-1], axis=1, out=c[:, 1:])
    return c


def smooth_run(loop: LoopRun, model: KalmanServo) -> SmoothedRun:
    """Filter and RTS-smooth a recorded run with ``model``'s (F, Q, H, R) and priors (see the module docstring)."""
    if not isinstance(model, KalmanServo):
        raise TypeError(f"model == {model!r}, must be a KalmanServo (its model is the one smoothed with)")
    F, Q, H = model.model()
    P0 = model.prior_covariance()
    c = control_phase_s(loop)
    z_free = loop.offset_s - c
    # Each trial's first offset is taken out as a known constant (the filter starts there, as the jam
    # sync does) and put back at the end: the prior then only has to cover the first noise sample.
    first = np.argmax(np.isfinite(z_free), axis=1)
    z0 = z_free[np.arange(z_free.shape[0]), first]
    z0 = np.where(np.isfinite(z0), z0, 0.0)[:, None]
    kf = KalmanFilter(F, Q, H, np.array([[model.design()[1] ** 2]]), np.zeros(F.shape[0]), P0).fit()
    filtered = kf.run((z_free - z0)[:, :, None])
    smoothed = rts_smooth(filtered, F)
    return SmoothedRun(filtered.x[:, :, 0] + c + z0, smoothed.x[:, :, 0] + c + z0, np.sqrt(smoothed.P[:, :, 0, 0]))
