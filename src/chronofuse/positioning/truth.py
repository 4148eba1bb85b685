"""Navigation truth of a vehicle, and the perfect IMU readings that reproduce it (inverse mechanization).

The path comes from the one trajectory model, :class:`chronofuse.models.kinematics.Trajectory`, read in a
local north-east-down frame at ``origin`` (metres from the origin, velocity in m/s): its NED velocity is
the truth velocity. Attitude follows the velocity as a ground vehicle's does: yaw along the horizontal
velocity, pitch along the climb, no roll (held when the vehicle stops). Latitude, longitude and height are
integrated from the velocity with the same trapezoid rule as :func:`chronofuse.positioning.ins.propagate`,
and :func:`imu_truth` inverts that mechanization step by step, so a perfect IMU fed to ``propagate``
returns the truth to rounding (the test of both).

Inverse of each step ``k -> k+1`` (Groves 2013, 5.4, solved for the sensor outputs)::

    exp([alpha x]) = C(k)' exp([omega_in dt x]) C(k+1),  omega_ib^b = alpha / dt   (alpha by the matrix log)
    f^n = (v(k+1) - v(k)) / dt - g^n + (omega_en + 2 omega_ie) x v(k),   f^b = ((C(k) + C(k+1)) / 2)^-1 f^n
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from chronofuse.models.kinematics import Trajectory
from chronofuse.positioning.earth import earth_rate_ned, normal_gravity_m_per_s2, radii_of_curvature_m, transport_rate_ned
from chronofuse.positioning.ins import _radii, _rodrigues, euler_to_dcm
from chronofuse.validation import check_array, check_scalar

__all__ = ["NavigationTruth", "navigation_truth", "imu_truth", "dcm_log", "integrate_lat_lon_reference"]


@dataclass(frozen=True)
class NavigationTruth:
    """True navigation state at every IMU epoch, ``steps + 1`` of them (the first is the start).

    ``t_s`` (steps + 1,); ``lat_lon_h`` (trials, steps + 1, 3) rad, rad, m; ``v_ned_m_per_s`` (trials,
    steps + 1, 3); ``c_bn`` (trials, steps + 1, 3, 3); ``rate_hz`` the IMU rate.
    """

    t_s: np.ndarray
    lat_lon_h: np.ndarray
    v_ned_m_per_s: np.ndarray
    c_bn: np.ndarray
    rate_hz: float


def _attitude(v_ned: np.ndarray) -> np.ndarray:
    """Body-to-NED DCM (trials, k, 3, 3): yaw along the horizontal velocity, pitch along the climb, no roll."""
    horizontal = np.hypot(v_ned[..., 0], v_ned[..., 1])
    yaw = np.arctan2(v_ned[..., 1], v_ned[..., 0])
    pitch = np.arctan2(-v_ned[..., 2], horizontal)
    # Hold the heading while (nearly) at rest: each epoch takes the angles of the last moving one.
    moving = horizontal >= 0.1
    last = np.maximum.accumulate(np.where(moving, np.arange(yaw.shape[1]), 0), axis=1)
    rows = np.arange(yaw.shape[0])[:, None]
    return euler_to_dcm(np.zeros_like(yaw), pitch[rows, last], yaw[rows, last])


def navigation_truth(trajectory: Trajectory, origin_lat_lon_h, duration_s: float, rate_hz: float) -> NavigationTruth:
    """Sample ``trajectory`` (read as NED metres from ``origin``) at ``rate_hz`` for ``duration_s``.

    ``origin_lat_lon_h``: latitude and longitude in rad and height in m of the trajectory's origin.
    """
    check_scalar(duration_s, "duration_s", min_val=0.0, include_min=False)
    check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    origin = check_array(origin_lat_lon_h, "origin_lat_lon_h", ndim=1)
    if origin.shape != (3,) or abs(origin[0]) >= math.pi / 2 - 1e-3:
        raise ValueError(f"origin_lat_lon_h == {origin.tolist()}, must be (lat, lon, h) with |lat| < 90 deg")
    steps = int(round(duration_s * rate_hz))
    t = np.arange(steps + 1) / rate_hz
    trials = trajectory.trials
    v = trajectory.velocity_at(np.broadcast_to(t, (trials, steps + 1)))
    r0 = trajectory.position_at(np.zeros((trials, 1)))[:, 0]
    dt = 1.0 / rate_hz
    pos = np.empty((trials, steps + 1, 3))
    r_n0, r_e0 = radii_of_curvature_m(origin[0])
    pos[:, 0, 0] = origin[0] + r0[:, 0] / (r_n0 + origin[2])
    pos[:, 0, 2] = origin[2] - r0[:, 2]
    pos[:, 0, 1] = origin[1] + r0[:, 1] / ((r_e0 + origin[2]) * math.cos(origin[0]))
    h = pos[:, 0, 2] - 0.5 * dt * np.cumsum(v[:, :-1, 2] + v[:, 1:, 2], axis=1)
    pos[:, 1:, 2] = h
    _integrate_lat_lon(pos, np.ascontiguousarray(v), dt)
    return NavigationTruth(t_s=t, lat_lon_h=pos, v_ned_m_per_s=v, c_bn=_attitude(v), rate_hz=float(rate_hz))


def integrate_lat_lon_reference(pos: np.ndarray, v: np.ndarray, dt: float) -> None:
    """The numpy twin of :func:`_integrate_lat_lon`: fill ``pos[:, 1:, :2]`` (trials, steps + 1, 3) in place from
    the start ``pos[:, 0]``, the heights ``pos[..., 2]`` and velocities ``v`` (trials, steps + 1, 3), by the
    mechanization's trapezoid rule with its own choice of radii."""
    lat, lon = pos[:, 0, 0].copy(), pos[:, 0, 1].copy()
    h = pos[:, :, 2]
    for k in range(v.shape[1] - 1):
        r_n, r_e = radii_of_curvature_m(lat)
        lat_new = lat + 0.5 * (v[:, k, 0] / (r_n + h[:, k]) + v[:, k + 1, 0] / (r_n + h[:, k + 1])) * dt
        _, r_e_new = radii_of_curvature_m(lat_new)
        lon = lon + 0.5 * (v[:, k, 1] / ((r_e + h[:, k]) * np.cos(lat))
                           + v[:, k + 1, 1] / ((r_e_new + h[:, k + 1]) * np.cos(lat_new))) * dt
        lat = lat_new
        pos[:, k + 1, 0], pos[:, k + 1, 1] = lat, lon


@numba.njit(cache=True)
def _integrate_lat_lon(pos, v, dt):
    """Numba kernel of :func:`integrate_lat_lon_reference` (the same recurrence, a sequential loop)."""
    for i in range(pos.shape[0]):
        lat, lon = pos[i, 0, 0], pos[i, 0, 1]
        for k in range(v.shape[1] - 1):
            r_n, r_e = _radii(lat)
            h0, h1 = pos[i, k, 2], pos[i, k + 1, 2]
            lat_new = lat + 0.5 * (v[i, k, 0] / (r_n + h0) + v[i, k + 1, 0] / (r_n + h1)) * dt
            r_e_new = _radii(lat_new)[1]
            lon = lon + 0.5 * (v[i, k, 1] / ((r_e + h0) * math.cos(lat))
                               + v[i, k + 1, 1] / ((r_e_new + h1) * math.cos(lat_new))) * dt
            lat = lat_new
            pos[i, k + 1, 0], pos[i, k + 1, 1] = lat, lon


def dcm_log(m: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of rotation matrices (..., 3, 3) with angles below pi (the inverse of Rodrigues)."""
    cos = np.clip((np.trace(m, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    angle = np.arccos(cos)
    vee = 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], -1)
    sin = np.sin(angle)
    small = sin < 1e-6
    scale = np.where(small, 1.0 + angle**2 / 6.0, angle / np.where(small, 1.0, sin))
    return vee * scale[..., None]


def imu_truth(truth: NavigationTruth) -> tuple[np.ndarray, np.ndarray]:
    """Perfect angular rate (rad/s) and specific force (m/s^2), (trials, steps, 3) each (module docstring)."""
    dt = 1.0 / truth.rate_hz
    lat, h = truth.lat_lon_h[:, :-1, 0], truth.lat_lon_h[:, :-1, 2]
    v0, v1 = truth.v_ned_m_per_s[:, :-1], truth.v_ned_m_per_s[:, 1:]
    c0, c1 = truth.c_bn[:, :-1], truth.c_bn[:, 1:]
    omega_in = earth_rate_ned(lat) + transport_rate_ned(lat, h, v0)
    frame = _rodrigues((omega_in * dt).reshape(-1, 3)).reshape(omega_in.shape + (3,))
    body = np.swapaxes(c0, -1, -2) @ frame @ c1
    gyro = dcm_log(body) / dt
    g = np.zeros_like(v0)
    g[..., 2] = normal_gravity_m_per_s2(lat, h)
    coriolis = np.cross(transport_rate_ned(lat, h, v0) + 2.0 * earth_rate_ned(lat), v0)
    f_n = (v1 - v0) / dt - g + coriolis
    accel = np.linalg.solve(0.5 * (c0 + c1), f_n[..., None])[..., 0]
    return gyro, accel
