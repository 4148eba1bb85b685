"""Tightly coupled GNSS/INS: the pseudoranges themselves update the INS error state, so 1-3 satellites help.

State (estimate minus truth): the 15 INS errors of :mod:`chronofuse.positioning.errors`, then the receiver
clock bias ``db`` (m) and drift ``dd`` (m/s), then one inter-system bias (m) per system after the first
(random constants). Per GNSS epoch (Groves 2013, 14.3.3): the INS runs through the interval's IMU samples
(biases removed), the error covariance is predicted with ``Phi = blockdiag(Phi_INS, [[1, T], [0, 1]], I)``
and the clock's process noise of the two-state model, ``q_b = c^2 h0 / 2``, ``q_d = c^2 2 pi^2 h_-2``
(Brown & Hwang; :mod:`chronofuse.models.clock`); each satellite ``n`` with a pseudorange gives

    z_n = rho_n - (|r_sat,n - r_ins| + b + b_s(n)) = e_n . dr - db - db_s(n) + noise,

``e_n`` the unit line of sight from the receiver to the satellite in NED, so ``H_n = [e_n', 0, ..., -1, 0,
-[s(n) = j]]`` and ``R = diag(sigma_n^2)``. A satellite without a pseudorange contributes a zero row with a
very large variance (no information). The corrections close the loop on the INS, its biases and the
clock; the error state returns to zero. ``step`` and ``run`` share :func:`_epoch`; ``run`` moves every
trial together and never changes the filter.

The pseudorange model is the simulation's (geometric range and clock, no light time or Earth rotation:
:mod:`chronofuse.gnss.simulate`); on real files the signal corrections of
:mod:`chronofuse.gnss.point_positioning` would come first.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pymap3d

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.estimation.interface import FrozenResult
from chronofuse.estimation.kalman import predict, update
from chronofuse.models.imu import ImuModel
from chronofuse.positioning.errors import N_STATES, ErrorModel, apply_correction, process_noise, transition
from chronofuse.positioning.ins import InsState, propagate
from chronofuse.validation import check_array, check_scalar

__all__ = ["TightlyCoupled", "TightResult", "smooth"]

_MISSING_VAR_M2 = 1e12


@dataclass(frozen=True)
class TightResult(FrozenResult):
    """Arrays (trials, epochs, ...): corrected INS ``lat_lon_h`` (rad, rad, m), ``v_ned_m_per_s``, the clock
    ``clock_m`` and biases ``isb_m``, the number of pseudoranges used ``n_used``, the posterior covariance
    diagonal ``P_diag``; for :func:`smooth`, as :class:`chronofuse.positioning.loose.CoupledResult` keeps
    them: the error-state ``x_prior`` (zeros) and ``x``, ``P_prior``, ``P``, the transitions ``phi``
    (``phi[:, k]`` carries epoch ``k-1`` to ``k``) and the INS before each update ``lat_lon_h_prior``.
    Read-only."""

    lat_lon_h: np.ndarray
    v_ned_m_per_s: np.ndarray
    clock_m: np.ndarray
    isb_m: np.ndarray
    n_used: np.ndarray
    P_diag: np.ndarray
    x_prior: np.ndarray
    P_prior: np.ndarray
    x: np.ndarray
    P: np.ndarray
    phi: np.ndarray
    lat_lon_h_prior: np.ndarray


def _ecef(lat_lon_h: np.ndarray) -> np.ndarray:
    x, y, z = pymap3d.geodetic2ecef(lat_lon_h[:, 0], lat_lon_h[:, 1], lat_lon_h[:, 2], deg=False)
    return np.stack([x, y, z], -1)


def _los_ned(lat_lon_h: np.ndarray, satellite_m: np.ndarray):
    """Ranges (N, S) and unit lines of sight receiver -> satellite in NED (N, S, 3)."""
    r = _ecef(lat_lon_h)
    d = satellite_m - r[:, None, :]
    rng = np.linalg.norm(d, axis=-1)
    u = d / rng[..., None]
    lat, lon = lat_lon_h[:, 0:1], lat_lon_h[:, 1:2]
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    north = -sl * co * u[..., 0] - sl * so * u[..., 1] + cl * u[..., 2]
    east = -so * u[..., 0] + co * u[..., 1]
    down = -cl * co * u[..., 0] - cl * so * u[..., 1] - sl * u[..., 2]
    return rng, np.stack([north, east, down], -1)


class TightlyCoupled:
    """Tightly coupled GNSS/INS filter (module docstring).

    Parameters
    ----------
    imu : ImuModel
    start_lat_lon_h, start_v_ned_m_per_s, start_c_bn : arrays (3,), (3,), (3, 3)
        Initial INS state (an alignment at a surveyed start).
    imu_rate_hz : float
    n_systems : int
        Systems in the pseudoranges (one clock, ``n_systems - 1`` inter-system biases).
    clock_h0, clock_hm2 : float
        The receiver oscillator's white-FM and random-walk-FM levels (fractional frequency PSD).
    sigma_r_m, sigma_v_m_per_s, sigma_psi_rad, sigma_clock_m, sigma_drift_m_per_s, sigma_isb_m : float
        Initial uncertainties.
    """

    inputs: ClassVar[tuple[str, ...]] = ("gyro_rad_per_s", "accel_m_per_s2", "satellite_m", "sigma_m", "system")

    def __init__(self, imu: ImuModel, start_lat_lon_h, start_v_ned_m_per_s, start_c_bn, imu_rate_hz: float, *,
                 n_systems: int = 1, clock_h0: float = 2e-19, clock_hm2: float = 6e-22, start_clock_m: float = 0.0,
                 sigma_r_m: float = 1.0, sigma_v_m_per_s: float = 0.1, sigma_psi_rad: float = 0.01,
                 sigma_clock_m: float = 1e3, sigma_drift_m_per_s: float = 10.0, sigma_isb_m: float = 100.0):
        self.imu = imu
        self.start_lat_lon_h = start_lat_lon_h
        self.start_v_ned_m_per_s = start_v_ned_m_per_s
        self.start_c_bn = start_c_bn
        self.imu_rate_hz = imu_rate_hz
        self.n_systems = n_systems
        self.clock_h0 = clock_h0
        self.clock_hm2 = clock_hm2
        self.start_clock_m = start_clock_m
        self.sigma_r_m = sigma_r_m
        self.sigma_v_m_per_s = sigma_v_m_per_s
        self.sigma_psi_rad = sigma_psi_rad
        self.sigma_clock_m = sigma_clock_m
        self.sigma_drift_m_per_s = sigma_drift_m_per_s
        self.sigma_isb_m = sigma_isb_m

    def fit(self, train=None) -> TightlyCoupled:
        """Validate and derive the error model; ``train`` is not used. Returns self."""
        if not isinstance(self.imu, ImuModel):
            raise TypeError(f"imu == {self.imu!r}, must be an ImuModel")
        check_scalar(self.imu_rate_hz, "imu_rate_hz", min_val=10.0)
        check_scalar(self.n_systems, "n_systems", min_val=1, integer=True)
        self.model_ = ErrorModel.from_imu(self.imu)
        self.n_ = N_STATES + 2 + self.n_systems - 1
        self.start_ = InsState(check_array(self.start_lat_lon_h, "start_lat_lon_h", ndim=1)[None, :],
                               check_array(self.start_v_ned_m_per_s, "start_v_ned_m_per_s", ndim=1)[None, :],
                               check_array(self.start_c_bn, "start_c_bn", ndim=2)[None, :, :])
        P0 = np.zeros((self.n_, self.n_))
        P0[:N_STATES, :N_STATES] = self.model_.initial_covariance(self.sigma_r_m, self.sigma_v_m_per_s,
                                                                  self.sigma_psi_rad)
        P0[N_STATES, N_STATES] = self.sigma_clock_m**2
        P0[N_STATES + 1, N_STATES + 1] = self.sigma_drift_m_per_s**2
        for j in range(N_STATES + 2, self.n_):
            P0[j, j] = self.sigma_isb_m**2
        self.P0_ = P0
        self.q_clock_ = (SPEED_OF_LIGHT_M_PER_S**2 * self.clock_h0 / 2.0,
                         SPEED_OF_LIGHT_M_PER_S**2 * 2.0 * np.pi**2 * self.clock_hm2)
        return self

    def _check_fitted(self):
        if not hasattr(self, "model_"):
            raise RuntimeError("this TightlyCoupled filter is not fitted yet: call fit() first")

    def _epoch(self, state, ba, bg, clock, isb, P, gyro, accel, rho, sat, sigma, system):
        """One GNSS epoch for every trial (module docstring); returns the new state and the epoch's record."""
        dt_imu = 1.0 / self.imu_rate_hz
        prior, _ = propagate(state, gyro - bg[:, None, :], accel - ba[:, None, :], dt_imu)
        T = gyro.shape[1] * dt_imu
        f_b = (accel - ba[:, None, :]).mean(axis=1)
        f_ned = np.einsum("nij,nj->ni", prior.c_bn, f_b)
        phi15 = transition(f_ned, prior.c_bn, prior.lat_lon_h[:, 0], self.model_, T)
        q15 = process_noise(phi15, prior.c_bn, self.model_, T)
        trials, n = P.shape[0], self.n_
        phi = np.broadcast_to(np.eye(n), (trials, n, n)).copy()
        phi[:, :N_STATES, :N_STATES] = phi15
        phi[:, N_STATES, N_STATES + 1] = T
        q = np.zeros((trials, n, n))
        q[:, :N_STATES, :N_STATES] = q15
        qb, qd = self.q_clock_
        q[:, N_STATES, N_STATES] = qb * T + qd * T**3 / 3.0
        q[:, N_STATES, N_STATES + 1] = q[:, N_STATES + 1, N_STATES] = qd * T**2 / 2.0
        q[:, N_STATES + 1, N_STATES + 1] = qd * T
        pred = predict(np.zeros((trials, n)), P, phi, q)
        rng, los = _los_ned(prior.lat_lon_h, sat)
        onehot = (system[:, None] == np.arange(1, self.n_systems)[None, :]).astype(np.float64)  # (S, k-1)
        predicted = rng + clock[:, :1] + (isb[:, None, :] * onehot[None]).sum(-1)
        ok = np.isfinite(rho) & np.isfinite(rng)
        z = np.where(ok, rho - predicted, 0.0)
        S = rho.shape[1]
        H = np.zeros((trials, S, n))
        H[..., 0:3] = los
        H[..., N_STATES] = -1.0
        H[..., N_STATES + 2:] = -onehot[None]
        H = np.where(ok[..., None], H, 0.0)
        R = np.zeros((trials, S, S))
        R[:, np.arange(S), np.arange(S)] = np.where(ok, sigma**2, _MISSING_VAR_M2)
        post = update(pred.x, pred.P, z, H, R)
        dx = post.x
        corrected, ba_new, bg_new = apply_correction(prior, ba, bg, dx[:, :N_STATES])
        # ``clock`` holds this epoch's nominal bias and drift; corrected, then the bias is carried to the
        # next epoch by the drift (the nominal follows the transition's [1, T] row)
        bias = clock[:, 0] - dx[:, N_STATES]
        drift = clock[:, 1] - dx[:, N_STATES + 1]
        clock_new = np.stack([bias + T * drift, drift], -1)
        isb_new = isb - dx[:, N_STATES + 2:]
        rec = {"lat_lon_h": corrected.lat_lon_h, "v_ned_m_per_s": corrected.v_ned_m_per_s,
               "clock_m": bias, "isb_m": isb_new, "n_used": ok.sum(-1),
               "P_diag": np.diagonal(post.P, axis1=-2, axis2=-1), "x_prior": pred.x, "P_prior": pred.P,
               "x": dx, "P": post.P, "phi": phi, "lat_lon_h_prior": prior.lat_lon_h}
        return corrected, ba_new, bg_new, clock_new, isb_new, post.P, rec

    def reset(self) -> None:
        """Return the streaming state to the start."""
        self._check_fitted()
        self._stream = (self.start_, np.zeros((1, 3)), np.zeros((1, 3)), np.array([[self.start_clock_m, 0.0]]),
                        np.zeros((1, self.n_systems - 1)), self.P0_[None].copy())

    def step(self, rho_m, *, gyro_rad_per_s, accel_m_per_s2, satellite_m, sigma_m, system) -> dict:
        """One GNSS epoch of one trial: pseudoranges (S,) (NaN: none), the interval's IMU samples (k, 3),
        satellites (S, 3); returns the epoch's record (arrays without the trial axis)."""
        if not hasattr(self, "_stream"):
            self.reset()
        rho = np.asarray(rho_m, dtype=np.float64)[None]
        state, ba, bg, clock, isb, P = self._stream
        *new, rec = self._epoch(state, ba, bg, clock, isb, P, np.asarray(gyro_rad_per_s, dtype=np.float64)[None],
                                np.asarray(accel_m_per_s2, dtype=np.float64)[None], rho,
                                np.asarray(satellite_m, dtype=np.float64)[None], np.asarray(sigma_m)[None],
                                np.asarray(system, dtype=np.intp))
        self._stream = tuple(new)
        return {k: v[0] for k, v in rec.items()}

    def run(self, rho_m, *, gyro_rad_per_s, accel_m_per_s2, satellite_m, sigma_m, system) -> TightResult:
        """All trials: pseudoranges ``rho_m`` (trials, epochs, S) (NaN: not received), IMU blocks (trials,
        epochs, k, 3), satellites (epochs, S, 3) ECEF, ``sigma_m`` (trials, epochs, S), ``system`` (S,)."""
        self._check_fitted()
        rho = check_array(rho_m, "rho_m", ndim=3, allow_nan=True)
        gyro = check_array(gyro_rad_per_s, "gyro_rad_per_s", ndim=4)
        accel = check_array(accel_m_per_s2, "accel_m_per_s2", ndim=4)
        sat = np.asarray(satellite_m, dtype=np.float64)
        trials, epochs, S = rho.shape
        if gyro.shape[:2] != (trials, epochs) or accel.shape != gyro.shape:
            raise ValueError(f"IMU blocks {gyro.shape}, {accel.shape} must be ({trials}, {epochs}, samples, 3)")
        if sat.shape != (epochs, S, 3):
            raise ValueError(f"satellite_m has shape {sat.shape}, must be ({epochs}, {S}, 3)")
        system = np.asarray(system, dtype=np.intp)
        state = InsState(*(np.repeat(a, trials, axis=0) for a in (self.start_.lat_lon_h, self.start_.v_ned_m_per_s,
                                                                   self.start_.c_bn)))
        ba, bg = np.zeros((trials, 3)), np.zeros((trials, 3))
        clock = np.zeros((trials, 2))
        clock[:, 0] = self.start_clock_m
        isb = np.zeros((trials, self.n_systems - 1))
        P = np.repeat(self.P0_[None], trials, axis=0)
        out = None
        for k in range(epochs):
            state, ba, bg, clock, isb, P, rec = self._epoch(state, ba, bg, clock, isb, P, gyro[:, k], accel[:, k],
                                                            rho[:, k], np.broadcast_to(sat[k], (trials, S, 3)),
                                                            np.asarray(sigma_m)[:, k], system)
            if out is None:
                out = {name: np.empty((trials, epochs) + np.shape(v)[1:], dtype=np.asarray(v).dtype)
                       for name, v in rec.items()}
            for name, v in rec.items():
                out[name][:, k] = v
        return TightResult(**out)


def smooth(result: TightResult) -> np.ndarray:
    """RTS-smoothed positions (trials, epochs, 3) (rad, rad, m) of a :class:`TightResult`: the recursion of
    :func:`chronofuse.positioning.loose.smooth` over the whole error state (INS, clock, biases), the prior
    INS position corrected by the smoothed position error."""
    from chronofuse.estimation.rts import rts_smooth

    smoothed = rts_smooth(result, result.phi)
    prior = result.lat_lon_h_prior
    trials, epochs = prior.shape[:2]
    flat = InsState(prior.reshape(-1, 3), np.zeros((trials * epochs, 3)),
                    np.broadcast_to(np.eye(3), (trials * epochs, 3, 3)))
    zeros = np.zeros((trials * epochs, 3))
    corrected, _, _ = apply_correction(flat, zeros, zeros, smoothed.x[..., :N_STATES].reshape(-1, N_STATES))
    return corrected.lat_lon_h.reshape(trials, epochs, 3)
