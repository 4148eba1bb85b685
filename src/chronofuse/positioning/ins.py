"""Strapdown inertial navigation in the local north-east-down frame, vectorized over trials.

The mechanization of Groves (2013) section 5.4, in its first-order form with exact attitude increments:

1. attitude: ``C(+) = exp(-[omega_in^n dt x]) C(-) exp([omega_ib^b dt x])`` with
   ``omega_in = omega_ie + omega_en`` (Groves 5.73, the precise form: both rotations by Rodrigues' formula,
   so the DCM stays orthonormal and a body at rest keeps its attitude exactly);
2. specific force in NED: ``f^n = (C(-) + C(+)) f^b / 2`` (5.48);
3. velocity: ``v(+) = v(-) + (f^n + g^n - (Omega_en^n + 2 Omega_ie^n) v(-)) dt`` (5.54), with
   ``g^n = [0, 0, g(L, h)]`` the normal plumb-bob gravity;
4. position by the trapezoid rule (5.56): ``h -= (v_D(-) + v_D(+)) dt / 2``, then latitude with
   ``v_N / (R_N + h)`` and longitude with ``v_E / ((R_E + h) cos L)``.

:func:`propagate` is the numba kernel (the time loop is genuinely sequential); :func:`propagate_reference` is
its readable numpy twin, one step at a time and vectorized over trials, which the tests compare.

Error growth of an unaided INS (Groves 14.2; Titterton & Weston 12.3): a horizontal accelerometer bias ``b``
moves the position by ``b (1 - cos(w_s t)) / w_s^2`` (``w_s`` the Schuler rate, period ~84.4 min): it peaks
at ``2 b / w_s^2`` (about 12.7 km per mg) and never grows without bound; a gyro bias tilts the platform and
grows the position error as ``g b_g (t - sin(w_s t) / w_s) / w_s^2``. :func:`schuler_accel_bias_error_m` and
:func:`schuler_gyro_bias_error_m` are these formulas; the vertical channel is unstable (exponential).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from chronofuse.positioning.earth import (
    A_M,
    B_M,
    E2,
    FLATTENING,
    MU_M3_PER_S2,
    OMEGA_IE_RAD_PER_S,
    earth_rate_ned,
    normal_gravity_m_per_s2,
    radii_of_curvature_m,
    schuler_rate_rad_per_s,
    transport_rate_ned,
)
from chronofuse.validation import check_array, check_scalar

__all__ = [
    "InsState",
    "propagate",
    "propagate_reference",
    "static_imu_truth",
    "euler_to_dcm",
    "schuler_accel_bias_error_m",
    "schuler_gyro_bias_error_m",
]


@dataclass(frozen=True)
class InsState:
    """Navigation state of ``N`` trials: ``lat_lon_h`` (N, 3) rad, rad, m; ``v_ned_m_per_s`` (N, 3);
    ``c_bn`` (N, 3, 3) the body-to-NED direction-cosine matrix."""

    lat_lon_h: np.ndarray
    v_ned_m_per_s: np.ndarray
    c_bn: np.ndarray

    def __post_init__(self):
        n = check_array(self.lat_lon_h, "lat_lon_h", ndim=2).shape[0]
        for name, shape in (("lat_lon_h", (n, 3)), ("v_ned_m_per_s", (n, 3)), ("c_bn", (n, 3, 3))):
            if np.shape(getattr(self, name)) != shape:
                raise ValueError(f"{name} has shape {np.shape(getattr(self, name))}, must be {shape}")


def euler_to_dcm(roll_rad, pitch_rad, yaw_rad) -> np.ndarray:
    """Body-to-NED DCM from roll, pitch, yaw (Groves 2.22, transposed), shape (..., 3, 3)."""
    r, p, y = (np.asarray(a, dtype=np.float64) for a in (roll_rad, pitch_rad, yaw_rad))
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.stack([
        np.stack([cp * cy, -cr * sy + sr * sp * cy, sr * sy + cr * sp * cy], axis=-1),
        np.stack([cp * sy, cr * cy + sr * sp * sy, -sr * cy + cr * sp * sy], axis=-1),
        np.stack([-sp, sr * cp, cr * cp], axis=-1),
    ], axis=-2)


def static_imu_truth(lat_rad: float, height_m: float, c_bn: np.ndarray, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Angular rate and specific force (steps, 3) of a body at rest on the rotating Earth.

    At rest ``omega_ib^b = C_nb omega_ie^n`` and ``f^b = -C_nb g^n`` (the mechanization's velocity equation
    with ``v = 0`` and ``dv/dt = 0``).
    """
    c_nb = np.asarray(c_bn, dtype=np.float64).T
    omega = c_nb @ earth_rate_ned(lat_rad)
    force = -c_nb @ np.array([0.0, 0.0, normal_gravity_m_per_s2(lat_rad, height_m)])
    return np.tile(omega, (steps, 1)), np.tile(force, (steps, 1))


def _skew(a: np.ndarray) -> np.ndarray:
    """The cross-product matrices ``[a x]`` (..., 3, 3) of vectors (..., 3)."""
    out = np.zeros(a.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -a[..., 2], a[..., 1]
    out[..., 1, 0], out[..., 1, 2] = a[..., 2], -a[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -a[..., 1], a[..., 0]
    return out


def _rodrigues(alpha: np.ndarray) -> np.ndarray:
    """``exp([alpha x]) = I + sin(t)/t [alpha x] + (1 - cos t)/t^2 [alpha x]^2``, ``t = |alpha|``, for (N, 3)."""
    angle = np.sqrt(np.einsum("ni,ni->n", alpha, alpha))[:, None, None]
    k = _skew(alpha)
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    a = np.where(small, 1.0 - angle**2 / 6.0, np.sin(angle) / safe)
    b = np.where(small, 0.5 - angle**2 / 24.0, (1.0 - np.cos(angle)) / safe**2)
    return np.eye(3) + a * k + b * (k @ k)


def _check_inputs(state: InsState, gyro, accel, dt_s):
    check_scalar(dt_s, "dt_s", min_val=0.0, include_min=False)
    gyro = check_array(gyro, "gyro_rad_per_s", ndim=3)
    accel = check_array(accel, "accel_m_per_s2", ndim=3)
    n = state.lat_lon_h.shape[0]
    if gyro.shape != accel.shape or gyro.shape[0] != n or gyro.shape[2] != 3:
        raise ValueError(f"gyro {gyro.shape} and accel {accel.shape} must both be ({n}, steps, 3)")
    return gyro, accel


def propagate_reference(state: InsState, gyro_rad_per_s, accel_m_per_s2, dt_s: float, *,
                        hold_height: bool = False):
    """The numpy twin of :func:`propagate`: same equations, one step at a time, vectorized over trials."""
    gyro, accel = _check_inputs(state, gyro_rad_per_s, accel_m_per_s2, dt_s)
    pos, v, c = state.lat_lon_h.copy(), state.v_ned_m_per_s.copy(), state.c_bn.copy()
    out_pos = np.empty((gyro.shape[0], gyro.shape[1], 3))
    for k in range(gyro.shape[1]):
        lat, h = pos[:, 0], pos[:, 2]
        omega = earth_rate_ned(lat) + transport_rate_ned(lat, h, v)
        c_new = _rodrigues(-omega * dt_s) @ c @ _rodrigues(gyro[:, k] * dt_s)
        f_n = np.einsum("nij,nj->ni", 0.5 * (c + c_new), accel[:, k])
        g = np.zeros_like(v)
        g[:, 2] = normal_gravity_m_per_s2(lat, h)
        coriolis = np.cross(transport_rate_ned(lat, h, v) + 2.0 * earth_rate_ned(lat), v)
        v_new = v + (f_n + g - coriolis) * dt_s
        if hold_height:
            v_new[:, 2] = 0.0
        h_new = h - 0.5 * (v[:, 2] + v_new[:, 2]) * dt_s
        r_n, r_e = radii_of_curvature_m(lat)
        lat_new = lat + 0.5 * (v[:, 0] / (r_n + h) + v_new[:, 0] / (r_n + h_new)) * dt_s
        r_n_new, r_e_new = radii_of_curvature_m(lat_new)
        lon_new = pos[:, 1] + 0.5 * (v[:, 1] / ((r_e + h) * np.cos(lat))
                                     + v_new[:, 1] / ((r_e_new + h_new) * np.cos(lat_new))) * dt_s
        pos = np.stack([lat_new, lon_new, h_new], axis=-1)
        v, c = v_new, c_new
        out_pos[:, k] = pos
    return InsState(pos, v, c), out_pos


@numba.njit(cache=True)
def _gravity(lat, h):
    s2 = math.sin(lat) ** 2
    g0 = 9.7803253359 * (1.0 + 1.931853e-3 * s2) / math.sqrt(1.0 - E2 * s2)
    m = OMEGA_IE_RAD_PER_S**2 * A_M**2 * B_M / MU_M3_PER_S2
    return g0 * (1.0 - 2.0 / A_M * (1.0 + FLATTENING + m - 2.0 * FLATTENING * s2) * h + 3.0 / A_M**2 * h * h)


@numba.njit(cache=True)
def _radii(lat):
    d = 1.0 - E2 * math.sin(lat) ** 2
    return A_M * (1.0 - E2) / d**1.5, A_M / math.sqrt(d)


@numba.njit(cache=True)
def _exp_skew(ax, ay, az, out):
    """``out = exp([a x])`` for the rotation vector ``a`` (Rodrigues)."""
    ang = math.sqrt(ax * ax + ay * ay + az * az)
    if ang < 1e-8:
        sa, sb = 1.0 - ang * ang / 6.0, 0.5 - ang * ang / 24.0
    else:
        sa, sb = math.sin(ang) / ang, (1.0 - math.cos(ang)) / (ang * ang)
    kx = ((0.0, -az, ay), (az, 0.0, -ax), (-ay, ax, 0.0))
    for r in range(3):
        for s in range(3):
            kk = kx[r][0] * kx[0][s] + kx[r][1] * kx[1][s] + kx[r][2] * kx[2][s]
            out[r, s] = (1.0 if r == s else 0.0) + sa * kx[r][s] + sb * kk


@numba.njit(cache=True, parallel=True)
def _propagate_kernel(pos, v, c, gyro, accel, dt, hold_height, out_pos):
    n = gyro.shape[0]
    for i in numba.prange(n):  # trials are independent: one thread each (2 cores on CI)
        _propagate_trial(i, pos, v, c, gyro, accel, dt, hold_height, out_pos)


@numba.njit(cache=True)
def _propagate_trial(i, pos, v, c, gyro, accel, dt, hold_height, out_pos):
    steps = gyro.shape[1]
    rot = np.empty((3, 3))
    frame = np.empty((3, 3))
    tmp = np.empty((3, 3))
    c_new = np.empty((3, 3))
    om = np.empty(3)
    cor = np.empty(3)
    fn = np.empty(3)
    lat, lon, h = pos[i, 0], pos[i, 1], pos[i, 2]
    vn, ve, vd = v[i, 0], v[i, 1], v[i, 2]
    ci = c[i].copy()
    for k in range(steps):
        r_n, r_e = _radii(lat)
        sl, cl = math.sin(lat), math.cos(lat)
        en = (ve / (r_e + h), -vn / (r_n + h), -ve * sl / cl / (r_e + h))  # transport rate
        ie = (OMEGA_IE_RAD_PER_S * cl, 0.0, -OMEGA_IE_RAD_PER_S * sl)
        for j in range(3):
            om[j] = en[j] + ie[j]
        _exp_skew(gyro[i, k, 0] * dt, gyro[i, k, 1] * dt, gyro[i, k, 2] * dt, rot)
        _exp_skew(-om[0] * dt, -om[1] * dt, -om[2] * dt, frame)
        for r in range(3):
            for s in range(3):
                tmp[r, s] = ci[r, 0] * rot[0, s] + ci[r, 1] * rot[1, s] + ci[r, 2] * rot[2, s]
        for r in range(3):
            for s in range(3):
                c_new[r, s] = frame[r, 0] * tmp[0, s] + frame[r, 1] * tmp[1, s] + frame[r, 2] * tmp[2, s]
        fx, fy, fz = accel[i, k, 0], accel[i, k, 1], accel[i, k, 2]
        for r in range(3):
            fn[r] = 0.5 * ((ci[r, 0] + c_new[r, 0]) * fx + (ci[r, 1] + c_new[r, 1]) * fy
                           + (ci[r, 2] + c_new[r, 2]) * fz)
        w = (en[0] + 2.0 * ie[0], en[1] + 2.0 * ie[1], en[2] + 2.0 * ie[2])
        cor[0] = w[1] * vd - w[2] * ve
        cor[1] = w[2] * vn - w[0] * vd
        cor[2] = w[0] * ve - w[1] * vn
        g = _gravity(lat, h)
        vn2 = vn + (fn[0] - cor[0]) * dt
        ve2 = ve + (fn[1] - cor[1]) * dt
        vd2 = 0.0 if hold_height else vd + (fn[2] + g - cor[2]) * dt
        h2 = h - 0.5 * (vd + vd2) * dt
        lat2 = lat + 0.5 * (vn / (r_n + h) + vn2 / (r_n + h2)) * dt
        r_n2, r_e2 = _radii(lat2)
        lon = lon + 0.5 * (ve / ((r_e + h) * cl) + ve2 / ((r_e2 + h2) * math.cos(lat2))) * dt
        lat, h, vn, ve, vd = lat2, h2, vn2, ve2, vd2
        ci[:, :] = c_new
        out_pos[i, k, 0], out_pos[i, k, 1], out_pos[i, k, 2] = lat, lon, h
    pos[i, 0], pos[i, 1], pos[i, 2] = lat, lon, h
    v[i, 0], v[i, 1], v[i, 2] = vn, ve, vd
    c[i] = ci


def propagate(state: InsState, gyro_rad_per_s, accel_m_per_s2, dt_s: float, *, hold_height: bool = False):
    """Propagate every trial through its IMU samples (N, steps, 3) each; returns (new state, positions).

    ``positions`` (N, steps, 3) holds latitude, longitude (rad) and height (m) after each sample. The input
    state is not modified. ``hold_height`` keeps the vertical velocity at zero (a perfectly height-aided
    vertical channel, as with a barometer): the unaided vertical channel is unstable, its error growing as
    ``exp(t / sqrt(R / 2g))`` (about 9.5 min), and through gravity it drags the horizontal channels along.
    """
    gyro, accel = _check_inputs(state, gyro_rad_per_s, accel_m_per_s2, dt_s)
    pos, v, c = state.lat_lon_h.copy(), state.v_ned_m_per_s.copy(), state.c_bn.copy()
    out = np.empty((gyro.shape[0], gyro.shape[1], 3))
    _propagate_kernel(pos, v, c, np.ascontiguousarray(gyro), np.ascontiguousarray(accel), float(dt_s), bool(hold_height), out)
    return InsState(pos, v, c), out


def schuler_accel_bias_error_m(bias_m_per_s2: float, t_s, lat_rad: float = 0.0) -> np.ndarray:
    """Horizontal position error of a level INS from a horizontal accelerometer bias: ``b (1 - cos w t) / w^2``."""
    w = schuler_rate_rad_per_s(lat_rad)
    return bias_m_per_s2 * (1.0 - np.cos(w * np.asarray(t_s, dtype=np.float64))) / w**2


def schuler_gyro_bias_error_m(bias_rad_per_s: float, t_s, lat_rad: float = 0.0) -> np.ndarray:
    """Horizontal position error from a horizontal gyro bias: ``g b (t - sin(w t) / w) / w^2`` (magnitude)."""
    w = schuler_rate_rad_per_s(lat_rad)
    t = np.asarray(t_s, dtype=np.float64)
    return normal_gravity_m_per_s2(lat_rad, 0.0) * bias_rad_per_s * (t - np.sin(w * t) / w) / w**2
