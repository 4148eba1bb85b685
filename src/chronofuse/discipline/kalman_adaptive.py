"""The source paper's weighted adaptive Kalman servo: ``R_k = lambda R`` from the windowed innovation spread.

Section 5.2, eqs. (4-5)-(4-6) of the GNSSDO paper: ``sigma_e`` is the standard deviation of the
innovations ``e = z - H s-`` over a sliding window of ``window`` samples; ``R_k = lambda R`` with
``lambda = lambda_max`` if ``sigma_e > sigma_th`` else ``lambda_min`` (distrust the measurements while the
innovations are wild). ``drift_ar1 < 1`` gives the paper's AR(1) drift (eq. (4-4):
``d_k = alpha d_{k-1} + w``, ``Phi[2, 2] = alpha``). The threshold defaults to ``threshold_factor`` times the
measurement noise in use, so a servo fitted to data (:meth:`~chronofuse.discipline.kalman.KalmanServo.fit`)
takes its threshold from the noise it learnt.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from pydantic import Field

from chronofuse.discipline.kalman import HEADER, KalmanServo, KalmanServoConfig, kf_post, kf_prior
from chronofuse.discipline.servo_kernel import SAMPLE
from chronofuse.models.oscillator import PowerLaw
from chronofuse.validation import check_scalar

__all__ = ["AdaptiveKalmanServo", "AdaptiveKalmanServoConfig", "sample_wakf"]


@numba.njit(SAMPLE, cache=True)
def sample_wakf(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    """Backend kernel; params slots: sigma_th (s), lambda_min, lambda_max, window; state after x, P: the window."""
    n = int(params[0])
    e, _ = kf_prior(offset_s, shift_s, applied, state, params)
    w = int(params[HEADER - 1])
    window = state[n + n * n:n + n * n + w]
    for a in range(w - 1):
        window[a] = window[a + 1]
    window[w - 1] = e
    count = 0
    tot = 0.0
    for a in range(w):
        if not math.isnan(window[a]):
            count += 1
            tot += window[a]
    mean = tot / max(count, 1)
    var = 0.0
    for a in range(w):
        if not math.isnan(window[a]):
            var += (window[a] - mean) ** 2
    var = var / max(count - 1, 1)
    sigma_e = math.sqrt(var) if count >= 2 else 0.0
    lam = params[HEADER - 2] if sigma_e > params[HEADER - 4] else params[HEADER - 3]
    return kf_post(offset_s, not math.isnan(offset_s), lam * (params[3] / weight), e, state, params, out)


class AdaptiveKalmanServoConfig(KalmanServoConfig):
    """Settings of the weighted adaptive Kalman servo (the Kalman servo's, and these)."""

    window: int = Field(10, ge=2, description="innovations in the sliding window (samples)")
    sigma_th_s: float | None = Field(None, gt=0.0, description="threshold on their standard deviation; None: "
                                                              "threshold_factor x the measurement noise (s)")
    threshold_factor: float = Field(2.0, gt=0.0, description="threshold in measurement-noise units (dimensionless)")
    lambda_min: float = Field(1.0, gt=0.0, description="R scale while the innovations are quiet (dimensionless)")
    lambda_max: float = Field(10.0, gt=0.0, description="R scale while they are wild (dimensionless)")


class AdaptiveKalmanServo(KalmanServo):
    """The weighted adaptive KF (module docstring).

    Extra parameters: ``window`` (innovations, >= 2), ``sigma_th_s`` (threshold on their standard
    deviation, s; default ``threshold_factor`` times the measurement noise), ``lambda_min`` and ``lambda_max``
    (>= lambda_min > 0).
    """

    name = "adaptive-kalman"
    kernel = sample_wakf

    def __init__(self, h: PowerLaw | None = None, measurement_sigma_s: float | None = None, *, window: int = 10,
                 sigma_th_s: float | None = None, threshold_factor: float = 2.0, lambda_min: float = 1.0,
                 lambda_max: float = 10.0, **kw):
        super().__init__(h, measurement_sigma_s, **kw)
        self.window = window
        self.sigma_th_s = sigma_th_s
        self.threshold_factor = threshold_factor
        self.lambda_min = lambda_min
        self.lambda_max = lambda_max

    def _check(self) -> None:
        super()._check()
        check_scalar(self.window, "window", min_val=2, integer=True)
        check_scalar(self.lambda_min, "lambda_min", min_val=0.0, include_min=False)
        check_scalar(self.lambda_max, "lambda_max", min_val=self.lambda_min)
        check_scalar(self.threshold_factor, "threshold_factor", min_val=0.0, include_min=False)
        if self.sigma_th_s is not None:
            check_scalar(self.sigma_th_s, "sigma_th_s", min_val=0.0, include_min=False)

    def _threshold_s(self) -> float:
        return self.sigma_th_s if self.sigma_th_s is not None else self.threshold_factor * self.design()[1]

    def _initial(self, n_loops):
        state = super()._initial(n_loops)
        state["window"] = np.full((n_loops, int(self.window)), np.nan)
        return state

    def _variant_params(self):
        return (float(self._threshold_s()), float(self.lambda_min), float(self.lambda_max), float(int(self.window)))

    def _variant_state(self):
        return int(self.window)

    def _kernel_initial(self, n_loops):
        state = super()._kernel_initial(n_loops)
        n = 3 + len(self._gm())
        state[:, n + n * n:n + n * n + int(self.window)] = np.nan  # the window: no innovation yet
        return state

    def _weigh(self, state, e, s0, r, valid):
        buf = np.concatenate([state["window"][:, 1:], e[:, None]], axis=1)  # NaN where no sample
        count = np.isfinite(buf).sum(axis=1)
        filled = np.where(np.isfinite(buf), buf, 0.0)
        mean = filled.sum(axis=1) / np.maximum(count, 1)
        var = (np.where(np.isfinite(buf), buf - mean[:, None], 0.0) ** 2).sum(axis=1) / np.maximum(count - 1, 1)
        sigma_e = np.where(count >= 2, np.sqrt(var), 0.0)
        lam = np.where(sigma_e > self._threshold_s(), self.lambda_max, self.lambda_min)
        return lam * r, valid, {"window": buf}
