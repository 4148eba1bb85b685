"""Calibration of a link's fixed reply delay (URT) while both nodes know true time, and its uncertainty.

A fixed reply asymmetry is not observable from two-way timestamps alone: it trades one for one with the
clock offset (``z1`` carries ``eps - t_p / 2``). The paper's batch method (its eqs. 19-21, kept as
:class:`~chronofuse.sync.urt.UrtCompensation` ``mode="paper"``) takes ``mean(z1) / alpha`` and so
removes the true offset with it. The calibration here uses a reference for the offset instead: while
both nodes are disciplined to GNSS, each compares its clock with GNSS time every
``reference_interval_s`` (white error ``reference_sigma_s`` per node), and the exchange at that instant
gives one sample of the URT through the complete measurement model (:mod:`chronofuse.sync.measurement`)::

    t_p,k = (z1_k - r_k - skew (T_B + T_i - 2 r_k) / 2 - known_k) / a_k,    a_k = -(1 + v_k / c) / 2,

with ``r_k`` the reference offset, ``skew`` the slope of a line fitted to the references, and
``known_k`` the geometric terms. The estimate is the mean over the ``duration_s`` window; its variance
``sum_k (sigma1_k^2 + 2 sigma_ref^2) / (N a_k)^2`` (``sigma1`` the exchange's own noise) is what the
bound carries as the calibration's uncertainty. The skew fit adds less than 1e-15 s.

The calibration uses the truth on purpose (the reference stands for GNSS time): it is the supervised step
of a link's life, done once, and kept through a GNSS loss.
"""

from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from chronofuse.sync.measurement import (
    known_offset_terms_s,
    offset_measurement_s,
    offset_noise_var_s2,
    skew_coefficient_s,
    urt_coefficient,
)
from chronofuse.validation import check_array

__all__ = ["CalibrationConfig", "UrtCalibration", "calibrate_urt"]


class CalibrationConfig(BaseModel):
    """How the URT is calibrated (module docstring); fields carry their units."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    duration_s: float = Field(600.0, gt=0.0, le=86400.0, description="length of the calibration window (s)")
    reference_interval_s: float = Field(1.0, gt=0.0, le=60.0, description="one GNSS time comparison every (s)")
    reference_sigma_s: float = Field(5e-9, ge=0.0, le=1e-6, description="white error of each node's GNSS time (s)")

    @model_validator(mode="after")
    def _two_comparisons(self):
        # fewer than two comparisons were rounded up to two before: a window the run did not have
        if self.duration_s < 2.0 * self.reference_interval_s:
            raise ValueError(f"must be >= {2.0 * self.reference_interval_s:g} s (two GNSS comparisons, one every "
                             f"{self.reference_interval_s:g} s), got {self.duration_s:g}")
        return self

    @property
    def comparisons(self) -> int:
        """Reference comparisons (and exchanges used) in the window (at least 2, the validator's rule)."""
        return int(round(self.duration_s / self.reference_interval_s))


class UrtCalibration(BaseModel):
    """A calibration's outcome per link (trials,): the URT estimate and its 1-sigma uncertainty, s."""

    model_config = ConfigDict(arbitrary_types_allowed=True, frozen=True)

    urt_s: np.ndarray
    sigma_s: np.ndarray


def calibrate_urt(t_i_s, t_b_s, t_r_s, velocity_m_s, a_los_velocity_m_s, toa_sigma_s, reference_offset_s, *,
                  t_s, urt_jitter_s: float, reference_sigma_s: float, velocity_sigma_m_s=0.0) -> UrtCalibration:
    """The URT per trial from exchanges (trials, n) and the reference offsets at them (module docstring).

    ``toa_sigma_s`` is each exchange's TOA sigma (from its SNR), ``t_s`` (n,) the comparison epochs;
    missing exchanges (NaN) are left out.
    """
    t_i = check_array(t_i_s, "t_i_s", ndim=2, allow_nan=True)
    ref = check_array(reference_offset_s, "reference_offset_s", ndim=2)
    t = np.asarray(t_s, dtype=np.float64)
    if ref.shape != t_i.shape or t.shape != (t_i.shape[1],):
        raise ValueError(f"reference_offset_s {ref.shape} and t_s {t.shape} must match t_i_s {t_i.shape}")
    tc = t - t.mean()
    skew = (ref * tc).sum(axis=1, keepdims=True) / (tc * tc).sum()
    z1 = offset_measurement_s(t_i, t_b_s, t_r_s)
    known = known_offset_terms_s(t_i, t_b_s, velocity_m_s, a_los_velocity_m_s, ref)
    coef = urt_coefficient(velocity_m_s)
    sample = (z1 - ref - skew * skew_coefficient_s(t_i, t_b_s, ref) - known) / coef
    var = (offset_noise_var_s2(toa_sigma_s, urt_jitter_s, velocity_sigma_m_s, t_i, t_b_s)
           + 2.0 * reference_sigma_s**2) / coef**2
    ok = np.isfinite(sample)
    n = ok.sum(axis=1)
    if np.any(n == 0):
        raise ValueError("a calibration window has no exchange: every one of them was lost")
    urt = np.where(ok, sample, 0.0).sum(axis=1) / n
    sigma = np.sqrt(np.where(ok, var, 0.0).sum(axis=1)) / n
    return UrtCalibration(urt_s=urt, sigma_s=sigma)
