"""The gated Kalman servo: a chi-square innovation gate in front of the update.

The update is skipped when ``e^2 / S`` (``e = z - H s-``, ``S = H P- H' + R``) exceeds the chi-square(1)
quantile at ``gate_pfa``; after ``max_rejects`` consecutive rejections the next sample is accepted again
(a persistent step is real, not an outlier).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from pydantic import Field
from scipy import stats

from chronofuse.discipline.kalman import HEADER, KalmanServo, KalmanServoConfig, kf_post, kf_prior
from chronofuse.discipline.servo_kernel import SAMPLE
from chronofuse.models.oscillator import PowerLaw
from chronofuse.validation import check_scalar

__all__ = ["GatedKalmanServo", "GatedKalmanServoConfig", "sample_gated"]


@numba.njit(SAMPLE, cache=True)
def sample_gated(offset_s, local_ts_s, weight, shift_s, applied, state, params, out):
    """Backend kernel; params slots: gamma (the chi-square(1) gate), max_rejects; state after x, P: the rejections."""
    n = int(params[0])
    e, s0 = kf_prior(offset_s, shift_s, applied, state, params)
    valid = not math.isnan(offset_s)
    r = params[3] / weight
    k = n + n * n
    outlier = valid and e * e / (s0 + r) > params[HEADER - 4]
    reject = outlier and not (state[k] >= params[HEADER - 3])
    if reject:
        state[k] += 1.0
    elif valid:
        state[k] = 0.0
    return kf_post(offset_s, valid and not reject, r, e, state, params, out)


class GatedKalmanServoConfig(KalmanServoConfig):
    """Settings of the gated Kalman servo (the Kalman servo's, and these)."""

    gate_pfa: float = Field(1e-3, gt=0.0, lt=1.0, description="probability that a good sample is rejected "
                                                              "(per sample, dimensionless)")
    max_rejects: int = Field(30, ge=1, description="consecutive rejections after which a sample is accepted (samples)")


class GatedKalmanServo(KalmanServo):
    """KF with chi-square innovation gating: reject ``e^2 / S > chi2_1.isf(gate_pfa)``; accept again after
    ``max_rejects`` consecutive rejections."""

    name = "gated-kalman"
    kernel = sample_gated

    def __init__(self, h: PowerLaw | None = None, measurement_sigma_s: float | None = None, *,
                 gate_pfa: float = 1e-3, max_rejects: int = 30, **kw):
        super().__init__(h, measurement_sigma_s, **kw)
        self.gate_pfa = gate_pfa
        self.max_rejects = max_rejects

    def _check(self) -> None:
        super()._check()
        check_scalar(self.gate_pfa, "gate_pfa", min_val=0.0, max_val=1.0, include_min=False, include_max=False)
        check_scalar(self.max_rejects, "max_rejects", min_val=1, integer=True)

    def _gamma(self) -> float:
        return float(stats.chi2.isf(self.gate_pfa, 1))

    def _initial(self, n_loops):
        state = super()._initial(n_loops)
        state["rejects"] = np.zeros(n_loops, dtype=np.int64)
        state["gamma"] = self._gamma()
        return state

    def _variant_params(self):
        return (self._gamma(), float(int(self.max_rejects)), 0.0, 0.0)

    def _variant_state(self):
        return 1

    def _weigh(self, state, e, s0, r, valid):
        gamma = state["gamma"]
        with np.errstate(invalid="ignore"):
            outlier = valid & (e * e / (s0 + r) > gamma)
        give_in = state["rejects"] >= self.max_rejects
        reject = outlier & ~give_in
        rejects = np.where(reject, state["rejects"] + 1, np.where(valid, 0, state["rejects"]))
        return np.full(e.shape, r), valid & ~reject, {"rejects": rejects, "gamma": gamma}
