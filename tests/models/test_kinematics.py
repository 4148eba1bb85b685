"""Trajectories: closed-form kinematics, continuity through manoeuvres, explicit shapes."""

import numpy as np
import pytest

from chronofuse.models.kinematics import constant_acceleration, constant_velocity, manoeuvre, radial_geometry


def test_constant_acceleration_position_is_the_closed_form_parabola():
    traj = constant_acceleration([1.0, 2.0, 3.0], [10.0, 0.0, -5.0], [0.5, -1.0, 2.0])
    t = np.array([[0.0, 1.0, 7.5]])
    expected = np.array([1.0, 2.0, 3.0]) + np.array([10.0, 0.0, -5.0]) * t[..., None] + 0.5 * np.array([0.5, -1.0, 2.0]) * t[..., None] ** 2
    np.testing.assert_allclose(traj.position_at(t), expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(traj.velocity_at(t)[0, 2], [10.0 + 0.5 * 7.5, -7.5, -5.0 + 15.0])


def test_manoeuvre_keeps_position_and_velocity_continuous_at_each_switch():
    acc = np.array([[0.0, 0.0, 0.0], [30.0, -20.0, 0.0], [-10.0, 0.0, 5.0]])
    traj = manoeuvre([0.0, 0.0, 1000.0], [200.0, 0.0, 0.0], [0.0, 2.0, 5.0], acc)
    for t_switch in (2.0, 5.0):
        before = traj.position_at(np.array([[t_switch - 1e-9]]))
        after = traj.position_at(np.array([[t_switch]]))
        np.testing.assert_allclose(before, after, atol=1e-5)
        np.testing.assert_allclose(traj.velocity_at(np.array([[t_switch - 1e-9]])), traj.velocity_at(np.array([[t_switch]])), atol=1e-6)
    # Numerical integration of the piecewise acceleration agrees with the stored segments.
    t = np.linspace(0.0, 8.0, 80001)
    a = acc[np.searchsorted([0.0, 2.0, 5.0], t, side="right") - 1]
    v = np.array([200.0, 0.0, 0.0]) + np.concatenate([[np.zeros(3)], np.cumsum((a[1:] + a[:-1]) / 2 * np.diff(t)[:, None], axis=0)])
    r = np.array([0.0, 0.0, 1000.0]) + np.concatenate([[np.zeros(3)], np.cumsum((v[1:] + v[:-1]) / 2 * np.diff(t)[:, None], axis=0)])
    np.testing.assert_allclose(traj.position_at(t[None, -1:])[0, 0], r[-1], atol=1e-2)


def test_a_trajectory_per_trial_evaluates_each_trial_on_its_own_path():
    traj = constant_velocity(np.zeros((3, 3)), np.array([[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]]))
    pos = traj.position_at(np.full((3, 1), 2.0))
    np.testing.assert_array_equal(pos[:, 0, 0], [2.0, 4.0, 6.0])
    with pytest.raises(ValueError, match="trials"):
        traj.position_at(np.zeros((2, 1)))


def test_shapes_are_rejected_not_reshaped():
    with pytest.raises(ValueError, match="position_m"):
        constant_velocity(np.zeros(4), np.zeros(3))
    with pytest.raises(ValueError, match="t_s"):
        constant_velocity(np.zeros(3), np.zeros(3)).position_at(np.zeros(5))


def test_radial_geometry_refuses_a_negative_distance():
    with pytest.raises(ValueError, match="distance_m"):
        radial_geometry(-1.0, 100.0)


def test_a_5_g_level_turn_turns_at_g_sqrt_24_keeping_its_speed_and_height():
    from chronofuse.models.kinematics import STANDARD_GRAVITY_M_S2, turn

    path = turn([0.0, 0.0, 3000.0], [250.0, 0.0, 0.0], load_factor_g=5.0, start_s=1.0, duration_s=10.0)
    t = np.array([[0.5, 3.0, 6.0, 10.9, 12.0]])
    a = path.acceleration_m_s2[0][np.searchsorted(path.segment_start_s, t[0], side="right") - 1]
    assert np.linalg.norm(a[0]) == 0.0 and np.linalg.norm(a[-1]) == 0.0
    np.testing.assert_allclose(np.linalg.norm(a[1:4], axis=1), STANDARD_GRAVITY_M_S2 * np.sqrt(24.0), rtol=1e-5)
    v = path.velocity_at(t)[0]
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 250.0, rtol=2e-5)
    heading = np.degrees(np.arctan2(v[-1, 1], v[-1, 0]))
    assert heading == pytest.approx(-np.degrees(10.0 * STANDARD_GRAVITY_M_S2 * np.sqrt(24.0) / 250.0), rel=1e-3)
    assert np.all(path.position_at(t)[0, :, 2] == 3000.0)


def test_a_pull_up_climbs_and_levels_off_again():
    from chronofuse.models.kinematics import climb

    path = climb([0.0, 0.0, 1000.0], [200.0, 0.0, 0.0], load_factor_g=3.0, start_s=1.0, pull_s=2.0, hold_s=4.0)
    v = path.velocity_at(np.array([[0.5, 4.0, 10.0]]))[0]
    assert v[0, 2] == 0.0 and v[1, 2] == pytest.approx(2 * 9.80665 * 2.0) and v[2, 2] == pytest.approx(0.0, abs=1e-9)


def test_a_path_on_the_rotating_earth_has_the_velocity_its_positions_imply():
    from chronofuse.constants import EARTH_ROTATION_RAD_PER_S as OMEGA
    from chronofuse.models.earth_frame import EarthRotating

    path = EarthRotating(constant_velocity([1e3, 2e3, 3e3], [100.0, -50.0, 5.0]), 45.0, 10.0, 500.0)
    t = np.array([[10.0]])
    h = 1e-3
    numeric = (path.position_at(t + h) - path.position_at(t - h)) / (2 * h)
    np.testing.assert_allclose(path.velocity_at(t), numeric, rtol=0, atol=1e-6)
    # at rest on the equator the inertial speed is omega R (465 m/s)
    still = EarthRotating(constant_velocity([0.0, 0, 0], [0.0, 0, 0]), 0.0, 0.0)
    assert np.linalg.norm(still.velocity_at(np.zeros((1, 1)))) == pytest.approx(OMEGA * 6378137.0, rel=1e-9)
