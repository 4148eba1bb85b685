"""Loosely coupled GNSS/INS: an error-state Kalman filter on the estimation interface, closed loop.

Each GNSS epoch (``Z[k]``: a position fix ``(lat, lon, h)``, NaN when there is none, with its NED
covariance): the INS (:func:`chronofuse.positioning.ins.propagate`) runs through the interval's IMU samples
with the current bias estimates removed; the 15-state error covariance is predicted over the interval
(:mod:`chronofuse.positioning.errors`); the fix updates the error state through the pure Kalman core
(:func:`chronofuse.estimation.kalman.update`, ``z = r_ins - r_gnss`` in NED metres); the estimated errors
are removed from the INS and the biases (closed loop) and the error state returns to zero.

``step`` and ``run`` share :func:`_epoch`; ``run`` moves every trial together (vectorized over trials,
the IMU loop in numba) and returns a frozen :class:`CoupledResult`, which keeps what
:func:`smooth` needs for Rauch–Tung–Striebel smoothing: the error-state priors and posteriors, the
transitions, and the INS state before each update. In error-state form the filter's "state" at epoch ``k``
is the estimated error of the *prior* INS solution, ``x(k) = dx+(k)`` with ``x-(k) = 0``, so the RTS
recursion of :func:`chronofuse.estimation.rts.rts_smooth` applies as it is, with time-varying transitions;
the smoothed position is the prior INS position corrected by the smoothed error.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from chronofuse.estimation.interface import FrozenResult
from chronofuse.estimation.kalman import predict, update
from chronofuse.estimation.rts import rts_smooth
from chronofuse.models.imu import ImuModel
from chronofuse.positioning.errors import (
    H_POSITION,
    N_STATES,
    ErrorModel,
    apply_correction,
    ned_difference_m,
    process_noise,
    transition,
)
from chronofuse.positioning.ins import InsState, propagate
from chronofuse.validation import check_array, check_scalar

__all__ = ["CoupledStep", "CoupledResult", "LooselyCoupled", "smooth"]

_FIELDS = ("x_prior", "P_prior", "x", "P", "y", "S", "d2", "skipped", "phi", "lat_lon_h", "lat_lon_h_prior",
           "v_ned_m_per_s", "bias_a_m_per_s2", "bias_g_rad_per_s")


@dataclass(frozen=True)
class CoupledStep:
    """One GNSS epoch of one trial (shapes without the trial axis; see :class:`CoupledResult`)."""

    x_prior: np.ndarray
    P_prior: np.ndarray
    x: np.ndarray
    P: np.ndarray
    y: np.ndarray
    S: np.ndarray
    d2: float
    skipped: bool
    phi: np.ndarray
    lat_lon_h: np.ndarray
    lat_lon_h_prior: np.ndarray
    v_ned_m_per_s: np.ndarray
    bias_a_m_per_s2: np.ndarray
    bias_g_rad_per_s: np.ndarray


@dataclass(frozen=True)
class CoupledResult(FrozenResult):
    """Arrays (trials, epochs, ...): error-state ``x_prior`` (zeros) and ``x`` (15,), ``P_prior``, ``P``,
    ``phi`` (15, 15; ``phi[:, k]`` carries epoch ``k-1`` to ``k``), innovation ``y`` (3,) and ``S`` (3, 3),
    ``d2``, ``skipped``; the corrected INS ``lat_lon_h`` (rad, rad, m), the INS before the update
    ``lat_lon_h_prior``, ``v_ned_m_per_s``, and the bias estimates. Read-only."""

    x_prior: np.ndarray
    P_prior: np.ndarray
    x: np.ndarray
    P: np.ndarray
    y: np.ndarray
    S: np.ndarray
    d2: np.ndarray
    skipped: np.ndarray
    phi: np.ndarray
    lat_lon_h: np.ndarray
    lat_lon_h_prior: np.ndarray
    v_ned_m_per_s: np.ndarray
    bias_a_m_per_s2: np.ndarray
    bias_g_rad_per_s: np.ndarray


def _epoch(state: InsState, ba, bg, P, gyro, accel, fix, fix_cov, model: ErrorModel, dt_imu: float):
    """One GNSS epoch for every trial: propagate, predict, update, correct. Returns the new filter state and
    the epoch's record (a dict of the :data:`_FIELDS`)."""
    prior_state, _ = propagate(state, gyro - bg[:, None, :], accel - ba[:, None, :], dt_imu)
    interval = gyro.shape[1] * dt_imu
    f_b = (accel - ba[:, None, :]).mean(axis=1)
    f_ned = np.einsum("nij,nj->ni", prior_state.c_bn, f_b)
    phi = transition(f_ned, prior_state.c_bn, prior_state.lat_lon_h[:, 0], model, interval)
    q = process_noise(phi, prior_state.c_bn, model, interval)
    x0 = np.zeros((P.shape[0], N_STATES))
    pred = predict(x0, P, phi, q)
    z = ned_difference_m(prior_state.lat_lon_h, fix)  # r_ins - r_gnss; NaN without a fix
    post = update(pred.x, pred.P, z, H_POSITION, fix_cov)
    corrected, ba_new, bg_new = apply_correction(prior_state, ba, bg, post.x)
    record = {"x_prior": pred.x, "P_prior": pred.P, "x": post.x, "P": post.P, "y": post.y, "S": post.S,
              "d2": post.d2, "skipped": post.skipped, "phi": phi, "lat_lon_h": corrected.lat_lon_h,
              "lat_lon_h_prior": prior_state.lat_lon_h, "v_ned_m_per_s": corrected.v_ned_m_per_s,
              "bias_a_m_per_s2": ba_new, "bias_g_rad_per_s": bg_new}
    return corrected, ba_new, bg_new, post.P, record


class LooselyCoupled:
    """GNSS/INS filter (module docstring).

    Parameters
    ----------
    imu : ImuModel
        The IMU's error model (the filter's noise densities come from it).
    start_lat_lon_h : array (3,)
        Initial INS position (rad, rad, m), e.g. the first GNSS fix.
    start_v_ned_m_per_s : array (3,)
        Initial velocity.
    start_c_bn : array (3, 3)
        Initial attitude (from an alignment).
    imu_rate_hz : float
        IMU sample rate; every epoch brings ``imu_rate_hz * interval`` samples.
    sigma_r_m, sigma_v_m_per_s, sigma_psi_rad : float
        Initial uncertainty of position, velocity and attitude.
    """

    inputs: ClassVar[tuple[str, ...]] = ("gyro_rad_per_s", "accel_m_per_s2", "fix_cov_ned_m2")

    def __init__(self, imu: ImuModel, start_lat_lon_h, start_v_ned_m_per_s, start_c_bn, imu_rate_hz: float, *,
                 sigma_r_m: float = 10.0, sigma_v_m_per_s: float = 1.0, sigma_psi_rad: float = 0.01):
        self.imu = imu
        self.start_lat_lon_h = start_lat_lon_h
        self.start_v_ned_m_per_s = start_v_ned_m_per_s
        self.start_c_bn = start_c_bn
        self.imu_rate_hz = imu_rate_hz
        self.sigma_r_m = sigma_r_m
        self.sigma_v_m_per_s = sigma_v_m_per_s
        self.sigma_psi_rad = sigma_psi_rad

    def fit(self, train=None) -> LooselyCoupled:
        """Validate the parameters and derive the error model; ``train`` is not used. Returns self."""
        if not isinstance(self.imu, ImuModel):
            raise TypeError(f"imu == {self.imu!r}, must be an ImuModel")
        check_scalar(self.imu_rate_hz, "imu_rate_hz", min_val=10.0)
        self.model_ = ErrorModel.from_imu(self.imu)
        self.start_ = InsState(check_array(self.start_lat_lon_h, "start_lat_lon_h", ndim=1)[None, :],
                               check_array(self.start_v_ned_m_per_s, "start_v_ned_m_per_s", ndim=1)[None, :],
                               check_array(self.start_c_bn, "start_c_bn", ndim=2)[None, :, :])
        self.P0_ = self.model_.initial_covariance(self.sigma_r_m, self.sigma_v_m_per_s, self.sigma_psi_rad)
        self.reset()
        return self

    def reset(self) -> None:
        """Return to the start state."""
        if hasattr(self, "model_"):
            self._state = self.start_
            self._ba, self._bg = np.zeros((1, 3)), np.zeros((1, 3))
            self._P = self.P0_[None].copy()

    def _check_fitted(self):
        if not hasattr(self, "model_"):
            raise RuntimeError("this LooselyCoupled filter is not fitted yet: call fit() first")

    def step(self, z, *, gyro_rad_per_s, accel_m_per_s2, fix_cov_ned_m2) -> CoupledStep:
        """One GNSS epoch: ``z`` the fix (3,) (NaN or None: no fix) and the interval's IMU samples (k, 3)."""
        self._check_fitted()
        fix = np.full((1, 3), np.nan) if z is None else np.asarray(z, dtype=np.float64).reshape(1, 3)
        gyro = np.asarray(gyro_rad_per_s, dtype=np.float64)[None]
        accel = np.asarray(accel_m_per_s2, dtype=np.float64)[None]
        self._state, self._ba, self._bg, self._P, rec = _epoch(
            self._state, self._ba, self._bg, self._P, gyro, accel, fix, np.asarray(fix_cov_ned_m2)[None],
            self.model_, 1.0 / self.imu_rate_hz)
        one = {k: (v[0] if np.ndim(v) else v) for k, v in rec.items()}
        return CoupledStep(**{k: (float(one[k]) if k == "d2" else bool(one[k]) if k == "skipped" else one[k])
                              for k in _FIELDS})

    def run(self, Z, *, gyro_rad_per_s, accel_m_per_s2, fix_cov_ned_m2) -> CoupledResult:
        """All trials: ``Z`` (trials, epochs, 3) fixes, IMU (trials, epochs, k, 3), covariances (trials, epochs,
        3, 3). The filter's own streaming state is not touched."""
        self._check_fitted()
        Z = check_array(Z, "Z", ndim=3, allow_nan=True)
        gyro = check_array(gyro_rad_per_s, "gyro_rad_per_s", ndim=4)
        accel = check_array(accel_m_per_s2, "accel_m_per_s2", ndim=4)
        trials, epochs = Z.shape[:2]
        if gyro.shape[:2] != (trials, epochs) or accel.shape != gyro.shape:
            raise ValueError(f"IMU blocks {gyro.shape}, {accel.shape} must be ({trials}, {epochs}, samples, 3)")
        cov = np.asarray(fix_cov_ned_m2, dtype=np.float64)
        state = InsState(*(np.repeat(a, trials, axis=0) for a in (self.start_.lat_lon_h, self.start_.v_ned_m_per_s,
                                                                   self.start_.c_bn)))
        ba, bg = np.zeros((trials, 3)), np.zeros((trials, 3))
        P = np.repeat(self.P0_[None], trials, axis=0)
        out = None
        for k in range(epochs):
            state, ba, bg, P, rec = _epoch(state, ba, bg, P, gyro[:, k], accel[:, k], Z[:, k], cov[:, k],
                                           self.model_, 1.0 / self.imu_rate_hz)
            if out is None:
                out = {name: np.empty((trials, epochs) + np.shape(v)[1:], dtype=np.asarray(v).dtype)
                       for name, v in rec.items()}
            for name, v in rec.items():
                out[name][:, k] = v
        return CoupledResult(**out)


def smooth(result: CoupledResult) -> np.ndarray:
    """RTS-smoothed positions (trials, epochs, 3) (rad, rad, m) of a :class:`CoupledResult` (module docstring)."""
    smoothed = rts_smooth(result, result.phi)
    prior = result.lat_lon_h_prior
    trials, epochs = prior.shape[:2]
    flat = InsState(prior.reshape(-1, 3), np.zeros((trials * epochs, 3)), np.broadcast_to(np.eye(3), (trials * epochs, 3, 3)))
    zeros = np.zeros((trials * epochs, 3))
    corrected, _, _ = apply_correction(flat, zeros, zeros, smoothed.x.reshape(-1, N_STATES))
    return corrected.lat_lon_h.reshape(trials, epochs, 3)
