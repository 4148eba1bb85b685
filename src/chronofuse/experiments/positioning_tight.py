"""Loose against tight coupling when only two or three satellites are left for a minute.

The drive (:func:`chronofuse.positioning.scenario.simulate_drive`, open-sky budget, industrial IMU) keeps
only the ``keep`` highest satellites from ``window`` (s) on: no single-point fix exists there, so the loosely
coupled filter runs on its INS alone, while the tightly coupled one still takes the ``keep`` pseudoranges.
The statistic is the largest horizontal error inside the window, per drive.
"""

from __future__ import annotations

import numpy as np
import pymap3d

from chronofuse.models.imu import imu_grade
from chronofuse.positioning.errors import ned_difference_m
from chronofuse.positioning.loose import LooselyCoupled
from chronofuse.positioning.scenario import simulate_drive
from chronofuse.positioning.tight import TightlyCoupled

__all__ = ["few_satellites", "run_tight", "horizontal_errors_m", "few_satellites_experiment"]


def few_satellites(drive, keep: int, window: slice):
    """The drive's pseudoranges with only the ``keep`` highest satellites inside ``window`` (epochs), and its
    fixes with none there (fewer than four satellites give no single-point fix)."""
    rho = drive.pseudorange_m.copy()
    t = drive.truth
    lat, lon, h = t.lat_lon_h[0, 1:, 0], t.lat_lon_h[0, 1:, 1], t.lat_lon_h[0, 1:, 2]
    rx = np.stack(pymap3d.geodetic2ecef(lat, lon, h, deg=False), -1)
    d = drive.satellite_m - rx[:, None, :]
    e, n, u = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat[:, None], lon[:, None], deg=False)
    elevation = np.arctan2(u, np.hypot(e, n))
    for k in range(window.start, window.stop):
        seen = np.isfinite(rho[:, k]).all(0)
        order = np.argsort(-np.where(seen, elevation[k], -np.inf))
        rho[:, k, order[keep:]] = np.nan
    fixes = drive.fix_lat_lon_h.copy()
    fixes[:, window] = np.nan
    return rho, fixes


def run_tight(imu, drive, rho):
    """The tightly coupled filter on ``rho`` (its clock started from the first epoch at the known start)."""
    t = drive.truth
    start = t.lat_lon_h[0, 0]
    x0 = np.array(pymap3d.geodetic2ecef(*start, deg=False))
    first = np.isfinite(rho[0, 0])
    clock0 = float(np.nanmean(rho[0, 0, first] - np.linalg.norm(drive.satellite_m[0, first] - x0, axis=-1)))
    filt = TightlyCoupled(imu, start, t.v_ned_m_per_s[0, 0], t.c_bn[0, 0], drive.imu_rate_hz,
                          start_clock_m=clock0, sigma_clock_m=30.0).fit()
    return filt, filt.run(rho, gyro_rad_per_s=drive.gyro_rad_per_s, accel_m_per_s2=drive.accel_m_per_s2,
                          satellite_m=drive.satellite_m, sigma_m=drive.sigma_m, system=drive.system)


def horizontal_errors_m(lat_lon_h, truth) -> np.ndarray:
    """Horizontal error (m) of positions (trials, epochs, 3) against the drive's truth."""
    err = ned_difference_m(lat_lon_h, np.broadcast_to(truth.lat_lon_h[:, 1:], lat_lon_h.shape))
    return np.hypot(err[..., 0], err[..., 1])


def few_satellites_experiment(keep: int, *, trials: int = 4, seed: int = 11, duration_s: float = 300.0,
                              window: slice = slice(200, 260)) -> dict:
    """Largest horizontal error inside the window, per drive, tight and loose (module docstring)."""
    imu = imu_grade("industrial")
    drive = simulate_drive("open-sky", "gps", imu, duration_s, trials, seed=seed)
    rho, fixes = few_satellites(drive, keep, window)
    t = drive.truth
    _, tight = run_tight(imu, drive, rho)
    loose = LooselyCoupled(imu, t.lat_lon_h[0, 0], t.v_ned_m_per_s[0, 0], t.c_bn[0, 0], drive.imu_rate_hz,
                           sigma_r_m=1.0, sigma_v_m_per_s=0.1, sigma_psi_rad=0.01).fit()
    free = loose.run(fixes, gyro_rad_per_s=drive.gyro_rad_per_s, accel_m_per_s2=drive.accel_m_per_s2,
                     fix_cov_ned_m2=drive.fix_cov_ned_m2)
    return {"keep": keep, "trials": trials, "window_s": window.stop - window.start,
            "tight_max_m": horizontal_errors_m(tight.lat_lon_h, t)[:, window].max(1).tolist(),
            "loose_max_m": horizontal_errors_m(free.lat_lon_h, t)[:, window].max(1).tolist(),
            "n_used": int(np.median(tight.n_used[:, window]))}
