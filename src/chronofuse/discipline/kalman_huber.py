"""The Huber Kalman servo: Huber's weight on the update, ``R / min(1, c / |e / sqrt(S)|)``.

One iteratively-reweighted step of a Huber M-estimator (Z. M. Durovic and B. D. Kovacevic, "Robust
estimation with unknown noise statistics", IEEE TAC 44(6), 1999): innovations beyond ``c`` standard
deviations (``c = 1.345``: 95 % efficiency under Gaussian noise) count less.
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

__all__ = ["HuberKalmanServo", "HuberKalmanServoConfig", "sample_huber"]


@numba.njit(SAMPLE, cache=True)
def sample_huber(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    """Backend kernel; params slot: the Huber constant c."""
    e, s0 = kf_prior(offset_s, shift_s, applied, state, params)
    valid = not math.isnan(offset_s)
    r = params[3] / weight
    rn = abs(e if valid else 0.0) / math.sqrt(s0 + r)
    wgt = min(1.0, params[HEADER - 4] / max(rn, 1e-300))
    return kf_post(offset_s, valid, r / wgt, e, state, params, out)


class HuberKalmanServoConfig(KalmanServoConfig):
    """Settings of the Huber Kalman servo (the Kalman servo's, and this)."""

    huber_c: float = Field(1.345, gt=0.0, description="Huber's constant (innovation standard deviations)")


class HuberKalmanServo(KalmanServo):
    """KF with a Huber-weighted update: ``R / min(1, c / |e / sqrt(S)|)``, ``c = huber_c`` (default 1.345)."""

    name = "huber-kalman"
    kernel = sample_huber

    def __init__(self, h: PowerLaw | None = None, measurement_sigma_s: float | None = None, *,
                 huber_c: float = 1.345, **kw):
        super().__init__(h, measurement_sigma_s, **kw)
        self.huber_c = huber_c

    def _check(self) -> None:
        super()._check()
        check_scalar(self.huber_c, "huber_c", min_val=0.0, include_min=False)

    def _variant_params(self):
        return (float(self.huber_c), 0.0, 0.0, 0.0)

    def _weigh(self, state, e, s0, r, valid):
        r_norm = np.abs(np.where(valid, e, 0.0)) / np.sqrt(s0 + r)
        weight = np.minimum(1.0, self.huber_c / np.maximum(r_norm, 1e-300))
        return r / weight, valid, {}
