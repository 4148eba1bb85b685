"""The 15-state INS error model of a loosely coupled GNSS/INS filter, and how its corrections are applied.

Error state (all "estimate minus truth", NED, SI): ``dr`` position (m), ``dv`` velocity (m/s), ``psi``
attitude (rad; ``C_est = (I + [psi x]) C_true``), ``db_a`` accelerometer bias not yet removed (m/s^2),
``db_g`` gyro bias not yet removed (rad/s). Continuous dynamics (Groves 2013, 14.2.3, short-term form)::

    d(dr)/dt   = dv
    d(dv)/dt   = -[f^n x] psi + C_bn db_a + w_a
    d(psi)/dt  = -[omega_ie^n x] psi + C_bn db_g + w_g
    d(db)/dt   = -db / tau_b + w_b                 (first-order Gauss–Markov biases)

with white-noise densities from the IMU model: ``w_a`` the velocity random walk, ``w_g`` the angle random
walk, and ``w_b`` chosen so the stationary bias 1-sigma is the bias instability plus a random walk term.
Discretised over one GNSS interval ``T`` with ``Phi = I + F T + (F T)^2 / 2`` and ``Q = Phi G Qc G' Phi' T``
(Groves 3.4.3, second order). A GNSS position fix measures ``z = r_ins - r_gnss`` in NED metres,
``H = [I 0 0 0 0]``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.models.imu import ImuModel
from chronofuse.positioning.earth import earth_rate_ned, radii_of_curvature_m
from chronofuse.positioning.ins import InsState, _rodrigues, _skew

__all__ = ["N_STATES", "H_POSITION", "ErrorModel", "transition", "process_noise", "ned_difference_m",
           "apply_correction"]

N_STATES = 15
H_POSITION = np.hstack([np.eye(3), np.zeros((3, 12))])


@dataclass(frozen=True)
class ErrorModel:
    """Noise densities of the error state from an IMU model: ``vrw`` (m/s^2/sqrt(Hz)), ``arw`` (rad/s/sqrt(Hz)),
    bias 1-sigma ``sigma_ba``, ``sigma_bg`` and their correlation time ``tau_b_s``."""

    vrw: float
    arw: float
    sigma_ba: float
    sigma_bg: float
    tau_b_s: float = 300.0

    @classmethod
    def from_imu(cls, imu: ImuModel, tau_b_s: float = 300.0) -> ErrorModel:
        """Densities from the datasheet terms; the bias 1-sigma covers the turn-on bias and the in-run terms."""
        def sigma_b(err):
            # A bias state of zero variance would make every covariance singular (and the RTS gain undefined):
            # 1e-12 of the measured unit keeps it invertible without changing any result.
            return max(float(np.sqrt(err.turn_on_bias**2 + err.bias_instability**2
                                     + err.bias_random_walk**2 * tau_b_s)), 1e-12)
        return cls(vrw=imu.accel.white_density, arw=imu.gyro.white_density, sigma_ba=sigma_b(imu.accel),
                   sigma_bg=sigma_b(imu.gyro), tau_b_s=tau_b_s)

    def initial_covariance(self, sigma_r_m: float, sigma_v_m_per_s: float, sigma_psi_rad) -> np.ndarray:
        """Diagonal P0 (15, 15): position, velocity and attitude 1-sigmas given, biases at their stationary level."""
        psi = np.broadcast_to(np.asarray(sigma_psi_rad, dtype=np.float64), (3,))
        sig = np.r_[np.full(3, sigma_r_m), np.full(3, sigma_v_m_per_s), psi, np.full(3, self.sigma_ba),
                    np.full(3, self.sigma_bg)]
        return np.diag(sig**2)


def transition(f_ned: np.ndarray, c_bn: np.ndarray, lat_rad: np.ndarray, model: ErrorModel, interval_s: float):
    """``Phi`` (N, 15, 15) over one interval, from the mean specific force ``f_ned`` (N, 3), attitude (N, 3, 3)."""
    n = f_ned.shape[0]
    F = np.zeros((n, N_STATES, N_STATES))
    F[:, 0:3, 3:6] = np.eye(3)
    F[:, 3:6, 6:9] = -_skew(f_ned)
    F[:, 3:6, 9:12] = c_bn
    F[:, 6:9, 6:9] = -_skew(earth_rate_ned(lat_rad))
    F[:, 6:9, 12:15] = c_bn
    F[:, 9:15, 9:15] = -np.eye(6) / model.tau_b_s
    ft = F * interval_s
    return np.eye(N_STATES) + ft + ft @ ft / 2.0


def process_noise(phi: np.ndarray, c_bn: np.ndarray, model: ErrorModel, interval_s: float) -> np.ndarray:
    """``Q`` (N, 15, 15) over one interval: ``Phi G Qc G' Phi' T`` with the noise mapped through the attitude."""
    n = phi.shape[0]
    gqg = np.zeros((n, N_STATES, N_STATES))
    gqg[:, 3:6, 3:6] = model.vrw**2 * c_bn @ np.swapaxes(c_bn, -1, -2)
    gqg[:, 6:9, 6:9] = model.arw**2 * c_bn @ np.swapaxes(c_bn, -1, -2)
    gqg[:, 9:12, 9:12] = 2.0 * model.sigma_ba**2 / model.tau_b_s * np.eye(3)
    gqg[:, 12:15, 12:15] = 2.0 * model.sigma_bg**2 / model.tau_b_s * np.eye(3)
    q = phi @ gqg @ np.swapaxes(phi, -1, -2) * interval_s
    return 0.5 * (q + np.swapaxes(q, -1, -2))


def ned_difference_m(lat_lon_h: np.ndarray, reference_lat_lon_h: np.ndarray) -> np.ndarray:
    """``lat_lon_h - reference`` as north, east, down metres at the reference (small differences), (..., 3)."""
    a, b = np.asarray(lat_lon_h, dtype=np.float64), np.asarray(reference_lat_lon_h, dtype=np.float64)
    r_n, r_e = radii_of_curvature_m(b[..., 0])
    return np.stack([(a[..., 0] - b[..., 0]) * (r_n + b[..., 2]),
                     (a[..., 1] - b[..., 1]) * (r_e + b[..., 2]) * np.cos(b[..., 0]),
                     -(a[..., 2] - b[..., 2])], axis=-1)


def apply_correction(state: InsState, bias_a: np.ndarray, bias_g: np.ndarray, dx: np.ndarray):
    """Remove the estimated errors ``dx`` (N, 15) from the nominal state and biases (closed loop).

    Returns ``(state, bias_a, bias_g)``; the error state is zero afterwards.
    """
    pos = state.lat_lon_h
    r_n, r_e = radii_of_curvature_m(pos[:, 0])
    lat = pos[:, 0] - dx[:, 0] / (r_n + pos[:, 2])
    lon = pos[:, 1] - dx[:, 1] / ((r_e + pos[:, 2]) * np.cos(pos[:, 0]))
    h = pos[:, 2] + dx[:, 2]
    c = _rodrigues(-dx[:, 6:9]) @ state.c_bn  # C_true = exp(-[psi x]) C_est
    new = InsState(np.stack([lat, lon, h], -1), state.v_ned_m_per_s - dx[:, 3:6], c)
    return new, bias_a + dx[:, 9:12], bias_g + dx[:, 12:15]
