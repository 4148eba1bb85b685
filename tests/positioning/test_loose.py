"""Loosely coupled GNSS/INS: streaming equals batch, the filter's covariance is honest, smoothing helps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.estimation.interface import compare_streaming_to_batch
from chronofuse.models.imu import imu_grade
from chronofuse.positioning.errors import ned_difference_m
from chronofuse.positioning.loose import LooselyCoupled, smooth
from chronofuse.positioning.scenario import simulate_drive


def _filter(drive, grade: str) -> LooselyCoupled:
    t = drive.truth
    return LooselyCoupled(imu_grade(grade), t.lat_lon_h[0, 0], t.v_ned_m_per_s[0, 0], t.c_bn[0, 0], drive.imu_rate_hz,
                          sigma_r_m=1.0, sigma_v_m_per_s=0.1, sigma_psi_rad=0.01).fit()


def _run(f: LooselyCoupled, drive, fixes=None):
    return f.run(drive.fix_lat_lon_h if fixes is None else fixes, gyro_rad_per_s=drive.gyro_rad_per_s,
                 accel_m_per_s2=drive.accel_m_per_s2, fix_cov_ned_m2=drive.fix_cov_ned_m2)


def _errors_m(estimate, drive):
    truth = np.broadcast_to(drive.truth.lat_lon_h[:, 1:], estimate.shape)
    return ned_difference_m(estimate, truth)


@pytest.fixture(scope="module")
def drive():
    return simulate_drive("open-sky", "gps+bds", "tactical", 240, 3, seed=11, imu_rate_hz=50.0)


def test_streaming_equals_batch():
    small = simulate_drive("tunnel", "gps", "industrial", 12, 2, seed=2, imu_rate_hz=20.0)
    f = _filter(small, "industrial")
    problems = compare_streaming_to_batch(f, small.fix_lat_lon_h, rtol=1e-9, atol=1e-12,
                                          gyro_rad_per_s=small.gyro_rad_per_s, accel_m_per_s2=small.accel_m_per_s2,
                                          fix_cov_ned_m2=small.fix_cov_ned_m2)
    assert problems == []


def test_the_innovations_are_chi_square_with_three_degrees_of_freedom(drive):
    result = _run(_filter(drive, "tactical"), drive)
    d2 = result.d2[:, 10:]
    # The fixes' residual atmosphere is correlated in time, which a white-noise R does not describe; the
    # innovations stay within a factor of chi2(3)'s mean of 3.
    assert 1.0 < np.nanmean(d2) < 6.0


def test_the_filter_beats_raw_fixes_and_smoothing_beats_the_filter(drive):
    result = _run(_filter(drive, "tactical"), drive)
    raw = np.linalg.norm(_errors_m(drive.fix_lat_lon_h, drive)[..., :2], axis=-1)
    filtered = np.linalg.norm(_errors_m(result.lat_lon_h, drive)[..., :2], axis=-1)
    smoothed = np.linalg.norm(_errors_m(smooth(result), drive)[..., :2], axis=-1)
    rms = lambda e: math.sqrt(np.mean(e[:, 20:] ** 2))  # noqa: E731
    assert rms(smoothed) < rms(filtered) <= 1.05 * rms(raw)


def test_without_fixes_the_ins_drifts_inside_its_own_covariance(drive):
    no_fix = np.full_like(drive.fix_lat_lon_h, np.nan)
    result = _run(_filter(drive, "tactical"), drive, fixes=no_fix)
    err = _errors_m(result.lat_lon_h, drive)
    sigma_north = np.sqrt(result.P[..., 0, 0])
    assert (result.skipped).all()
    # The INS error grows, and stays within 4 sigma of the filter's own prediction.
    assert np.abs(err[:, -1, :2]).max() > np.abs(err[:, 5, :2]).max()
    assert (np.abs(err[..., 0]) < 4 * sigma_north + 0.5).all()


def test_an_imu_rate_under_10_hz_is_refused():
    f = LooselyCoupled(imu_grade("tactical"), [0.5, 2.0, 0.0], np.zeros(3), np.eye(3), 5.0)
    with pytest.raises(ValueError, match="imu_rate_hz"):
        f.fit()
