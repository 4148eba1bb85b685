"""Unaided strapdown INS against its analytic error growth (Schuler oscillation) and its numpy twin."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.positioning.earth import radii_of_curvature_m, schuler_rate_rad_per_s
from chronofuse.positioning.ins import (
    InsState,
    euler_to_dcm,
    propagate,
    propagate_reference,
    schuler_accel_bias_error_m,
    schuler_gyro_bias_error_m,
    static_imu_truth,
)


def _at_rest(lat_rad: float, trials: int, yaw_rad: float = 0.3) -> InsState:
    c = euler_to_dcm(0.0, 0.0, yaw_rad)
    return InsState(np.tile([lat_rad, 0.2, 100.0], (trials, 1)), np.zeros((trials, 3)), np.tile(c, (trials, 1, 1)))


def _north_east_error_m(positions: np.ndarray, start: InsState) -> tuple[np.ndarray, np.ndarray]:
    lat0, lon0, h0 = start.lat_lon_h[0]
    r_n, r_e = radii_of_curvature_m(lat0)
    return (positions[..., 0] - lat0) * (r_n + h0), (positions[..., 1] - lon0) * (r_e + h0) * math.cos(lat0)


def test_a_perfect_imu_at_rest_stays_put_for_an_hour():
    start = _at_rest(math.radians(45.0), 1)
    omega, force = static_imu_truth(math.radians(45.0), 100.0, start.c_bn[0], 36_000)
    _, pos = propagate(start, omega[None], force[None], 0.1)
    north, east = _north_east_error_m(pos, start)
    assert np.abs(north).max() < 0.05 and np.abs(east).max() < 0.05
    assert abs(pos[0, -1, 2] - 100.0) < 0.05


def test_the_numba_kernel_equals_its_numpy_twin():
    rng = np.random.default_rng(4)
    start = InsState(np.array([[0.7, 0.1, 50.0], [-0.3, 2.0, 900.0]]), rng.normal(0, 30, (2, 3)),
                     euler_to_dcm(rng.normal(0, 0.1, 2), rng.normal(0, 0.1, 2), rng.uniform(0, 6, 2)))
    gyro = rng.normal(0, 0.05, (2, 200, 3))
    accel = rng.normal(0, 1, (2, 200, 3)) + np.array([0, 0, -9.8])
    fast_state, fast = propagate(start, gyro, accel, 0.01)
    slow_state, slow = propagate_reference(start, gyro, accel, 0.01)
    held, held_pos = propagate(start, gyro, accel, 0.01, hold_height=True)
    held_ref, held_ref_pos = propagate_reference(start, gyro, accel, 0.01, hold_height=True)
    assert np.allclose(held_pos, held_ref_pos, rtol=0, atol=1e-9)
    assert np.allclose(fast, slow, rtol=0, atol=1e-9)
    assert np.allclose(fast_state.c_bn, slow_state.c_bn, rtol=0, atol=1e-12)
    assert np.allclose(fast_state.v_ned_m_per_s, slow_state.v_ned_m_per_s, rtol=0, atol=1e-9)


def test_an_accelerometer_bias_gives_the_schuler_oscillation_of_theory():
    # At the equator the Foucault (Earth-rate) coupling vanishes and the north channel is a pure Schuler loop.
    bias = 1e-3 * 9.80665  # 1 mg on the north axis (yaw 0: body x is north)
    start = _at_rest(0.0, 1, yaw_rad=0.0)
    omega, force = static_imu_truth(0.0, 100.0, start.c_bn[0], 10_000)
    force = force + np.array([bias, 0.0, 0.0])
    dt = 1.0
    _, pos = propagate(start, omega[None], force[None], dt, hold_height=True)
    north, _ = _north_east_error_m(pos, start)
    t = dt * np.arange(1, north.shape[1] + 1)
    theory = schuler_accel_bias_error_m(bias, t)
    assert np.abs(north[0] - theory).max() < 0.02 * theory.max()
    # Peak 2 b / w_s^2 ~ 12.7 km per mg, at half the Schuler period (~42 min).
    period_s = 2 * math.pi / schuler_rate_rad_per_s(0.0)
    assert period_s == pytest.approx(84.4 * 60, rel=0.01)
    first = t < period_s
    assert t[first][np.argmax(north[0][first])] == pytest.approx(period_s / 2, rel=0.02)
    assert north[0][first].max() == pytest.approx(2 * bias / schuler_rate_rad_per_s(0.0) ** 2, rel=0.02)


def test_a_gyro_bias_grows_the_position_error_as_theory_says():
    bias = 1.0 * math.pi / 180 / 3600  # 1 deg/h about the east axis tilts the platform about east
    start = _at_rest(0.0, 1, yaw_rad=0.0)
    omega, force = static_imu_truth(0.0, 100.0, start.c_bn[0], 3_000)
    omega = omega + np.array([0.0, bias, 0.0])
    _, pos = propagate(start, omega[None], force[None], 1.0, hold_height=True)
    north, _ = _north_east_error_m(pos, start)
    t = np.arange(1, 3_001, dtype=float)
    theory = schuler_gyro_bias_error_m(bias, t)
    assert np.abs(np.abs(north[0]) - theory).max() < 0.03 * theory.max()


def test_a_state_of_the_wrong_shape_is_refused():
    with pytest.raises(ValueError, match="c_bn"):
        InsState(np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((3, 3, 3)))
    with pytest.raises(ValueError, match="gyro"):
        propagate(_at_rest(0.1, 2), np.zeros((1, 5, 3)), np.zeros((1, 5, 3)), 0.01)
