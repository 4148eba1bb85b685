"""GNSS/INS filter speed: one hour at 100 Hz IMU and 1 Hz GNSS, 100 trials, against a per-step Python loop.

Ours: :class:`chronofuse.positioning.loose.LooselyCoupled.run`, vectorized over trials (the IMU loop in
numba). The baseline is the same filter written the plain way: per trial, per GNSS epoch, the INS stepped
sample by sample in Python (:func:`chronofuse.positioning.ins.propagate_reference` on one sample at a time)
and filterpy's ``KalmanFilter.predict``/``update`` with the same Phi, Q, H, R. The baseline is timed on a
slice (one trial, ``baseline_epochs`` epochs) and scaled to the full run per trial-epoch; ours runs whole.
Timing does not depend on the noise values, so the 100 trials reuse 10 simulated ones (the data are
simulated once, outside the timing).
"""

from __future__ import annotations

import time

import numpy as np
from filterpy.kalman import KalmanFilter as FilterpyKF

from chronofuse.models.imu import imu_grade
from chronofuse.positioning.errors import (
    H_POSITION,
    ErrorModel,
    apply_correction,
    ned_difference_m,
    process_noise,
    transition,
)
from chronofuse.positioning.ins import InsState, propagate_reference
from chronofuse.positioning.loose import LooselyCoupled
from chronofuse.positioning.scenario import simulate_drive


def _baseline(drive, grade: str, epochs: int) -> float:
    """The per-step Python filter on trial 0's first ``epochs`` epochs; returns seconds."""
    t = drive.truth
    model = ErrorModel.from_imu(imu_grade(grade))
    kf = FilterpyKF(dim_x=15, dim_z=3)
    kf.P = model.initial_covariance(1.0, 0.1, 0.01)
    kf.H = H_POSITION
    state = InsState(t.lat_lon_h[:, 0], t.v_ned_m_per_s[:, 0], t.c_bn[:, 0])
    ba, bg = np.zeros((1, 3)), np.zeros((1, 3))
    dt = 1.0 / drive.imu_rate_hz
    start = time.perf_counter()
    for k in range(epochs):
        gyro, accel = drive.gyro_rad_per_s[0, k], drive.accel_m_per_s2[0, k]
        for j in range(gyro.shape[0]):
            state, _ = propagate_reference(state, (gyro[j] - bg[0])[None, None], (accel[j] - ba[0])[None, None], dt)
        f_ned = state.c_bn[0] @ (accel - ba[0]).mean(axis=0)
        phi = transition(f_ned[None], state.c_bn, state.lat_lon_h[:, 0], model, gyro.shape[0] * dt)
        kf.x = np.zeros(15)
        kf.predict(F=phi[0], Q=process_noise(phi, state.c_bn, model, gyro.shape[0] * dt)[0])
        z = ned_difference_m(state.lat_lon_h, drive.fix_lat_lon_h[:1, k])
        if np.isfinite(z).all():
            kf.update(z[0], R=drive.fix_cov_ned_m2[0, k])
        state, ba, bg = apply_correction(state, ba, bg, kf.x[None])
    return time.perf_counter() - start


def run(quick: bool = False) -> list[dict]:
    duration, trials, baseline_epochs = (300.0, 20, 5) if quick else (3600.0, 100, 20)
    grade = "industrial"
    drive = simulate_drive("urban-canyon", "gps+bds", grade, duration, 10, seed=1)
    reps = trials // 10
    gyro = np.concatenate([drive.gyro_rad_per_s] * reps)
    accel = np.concatenate([drive.accel_m_per_s2] * reps)
    fixes = np.concatenate([drive.fix_lat_lon_h] * reps)
    cov = np.concatenate([drive.fix_cov_ned_m2] * reps)
    t = drive.truth
    filt = LooselyCoupled(imu_grade(grade), t.lat_lon_h[0, 0], t.v_ned_m_per_s[0, 0], t.c_bn[0, 0], 100.0,
                          sigma_r_m=1.0, sigma_v_m_per_s=0.1, sigma_psi_rad=0.01).fit()
    filt.run(fixes[:1, :3], gyro_rad_per_s=gyro[:1, :3], accel_m_per_s2=accel[:1, :3], fix_cov_ned_m2=cov[:1, :3])
    start = time.perf_counter()
    filt.run(fixes, gyro_rad_per_s=gyro, accel_m_per_s2=accel, fix_cov_ned_m2=cov)
    ours = time.perf_counter() - start
    per_trial_epoch = _baseline(drive, grade, baseline_epochs) / baseline_epochs
    baseline = per_trial_epoch * trials * int(duration)
    target = 60.0 if not quick else None
    return [{
        "name": f"GNSS/INS {duration / 3600:g} h at 100 Hz x {trials} trials",
        "ours_s": ours, "baseline": "per-step Python INS + filterpy KF (scaled)", "baseline_s": baseline,
        "ratio": baseline / ours, "target": "< 60 s" if target else "smoke", "passed": target is None or ours < target,
        "note": f"baseline timed on 1 trial x {baseline_epochs} epochs ({per_trial_epoch * 1e3:.1f} ms per trial-epoch), "
                "scaled to the run",
    }]
