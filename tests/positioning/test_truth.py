"""Vehicle truth and its inverse mechanization: a perfect IMU flown through the INS returns the truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.models.kinematics import manoeuvre
from chronofuse.positioning.ins import InsState, _rodrigues, propagate
from chronofuse.positioning.truth import _integrate_lat_lon, dcm_log, imu_truth, integrate_lat_lon_reference, navigation_truth

ORIGIN = np.array([math.radians(30.5), math.radians(114.3), 30.0])


def _drive():
    # 15 m/s north, a left turn, a climb, braking: piecewise constant accelerations in NED.
    return manoeuvre(np.zeros(3), [15.0, 0.0, 0.0], [0.0, 20.0, 40.0, 60.0, 80.0],
                     [[0.0, 0.0, 0.0], [-0.5, -1.5, 0.0], [0.3, 0.0, -0.2], [0.0, 0.5, 0.2], [-0.2, 0.0, 0.0]])


def test_a_perfect_imu_reproduces_the_driven_trajectory():
    truth = navigation_truth(_drive(), ORIGIN, 100.0, 100.0)
    gyro, accel = imu_truth(truth)
    start = InsState(truth.lat_lon_h[:, 0], truth.v_ned_m_per_s[:, 0], truth.c_bn[:, 0])
    end, pos = propagate(start, gyro, accel, 1.0 / truth.rate_hz)
    err_north = (pos[0, :, 0] - truth.lat_lon_h[0, 1:, 0]) * 6.37e6
    err_east = (pos[0, :, 1] - truth.lat_lon_h[0, 1:, 1]) * 6.37e6 * math.cos(ORIGIN[0])
    assert np.abs(err_north).max() < 1e-5 and np.abs(err_east).max() < 1e-5
    assert np.abs(pos[0, :, 2] - truth.lat_lon_h[0, 1:, 2]).max() < 1e-5
    assert np.allclose(end.c_bn, truth.c_bn[:, -1], atol=1e-10)


def test_the_attitude_follows_the_velocity_with_no_roll():
    truth = navigation_truth(_drive(), ORIGIN, 100.0, 10.0)
    c = truth.c_bn[0]
    forward = c[:, :, 0]  # body x in NED
    v = truth.v_ned_m_per_s[0]
    assert np.allclose(forward, v / np.linalg.norm(v, axis=1, keepdims=True), atol=1e-12)
    assert np.allclose(c[:, 2, 1], 0.0, atol=1e-12)  # body y stays horizontal: no roll


def test_the_matrix_log_inverts_rodrigues():
    rng = np.random.default_rng(2)
    vectors = rng.normal(0, 1, (50, 3))
    vectors *= (rng.uniform(0, 3, 50) / np.linalg.norm(vectors, axis=1))[:, None]
    vectors[0] = 0.0
    assert np.allclose(dcm_log(_rodrigues(vectors)), vectors, atol=1e-9)


def test_an_origin_at_the_pole_is_refused():
    with pytest.raises(ValueError, match="origin_lat_lon_h"):
        navigation_truth(_drive(), [math.pi / 2, 0, 0], 10.0, 10.0)


def test_the_position_kernel_equals_its_numpy_twin():
    truth = navigation_truth(_drive(), ORIGIN, 30.0, 50.0)
    fast = truth.lat_lon_h.copy()
    slow = truth.lat_lon_h.copy()
    fast[:, 1:, :2] = slow[:, 1:, :2] = 0.0
    v = np.ascontiguousarray(truth.v_ned_m_per_s)
    _integrate_lat_lon(fast, v, 1 / 50.0)
    integrate_lat_lon_reference(slow, v, 1 / 50.0)
    assert np.allclose(fast, slow, rtol=0, atol=1e-15)
