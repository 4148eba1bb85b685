"""Fixed-interval smoothing of a static or slowly moving receiver's single-point fixes.

A random-walk position ``x(k) = x(k-1) + w``, ``E[w w'] = q dt I`` (m^2), measured by each fix with
``R = diag(sigma_h^2, sigma_h^2, sigma_v^2)`` in the local east-north-up frame at the first fix: the
package's Kalman filter (:class:`chronofuse.estimation.filter.KalmanFilter`) forward, its one RTS smoother
(:func:`chronofuse.estimation.rts.rts_smooth`) backward. Epochs without a fix (NaN) are predicted through.
It removes the white part of the fix errors (code noise, fast multipath), not the residual atmosphere
correlated over tens of minutes.
"""

from __future__ import annotations

import numpy as np
import pymap3d

from chronofuse.estimation.filter import KalmanFilter
from chronofuse.estimation.rts import rts_smooth
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import check_scalar

__all__ = ["smooth_static_fixes"]


def smooth_static_fixes(position_m: np.ndarray, gps_ns: np.ndarray, *, q_m2_per_s: float = 0.01,
                        sigma_h_m: float = 1.0, sigma_v_m: float = 2.0) -> np.ndarray:
    """Smoothed ECEF positions (epochs, 3) of fixes ``position_m`` (epochs, 3) taken at ``gps_ns`` (a regular
    interval; module docstring)."""
    check_scalar(q_m2_per_s, "q_m2_per_s", min_val=0.0, include_min=False)
    p = np.asarray(position_m, dtype=np.float64)
    ok = np.isfinite(p).all(-1)
    if not ok.any():
        return p.copy()
    origin = p[np.flatnonzero(ok)[0]]
    lat, lon, h = pymap3d.ecef2geodetic(*origin, deg=True)
    d = p - origin
    e, n, u = pymap3d.uvw2enu(d[:, 0], d[:, 1], d[:, 2], lat, lon, deg=True)
    z = np.stack([e, n, u], -1)
    dt = float(np.median(np.diff(gps_ns))) / NS_PER_S if len(gps_ns) > 1 else 1.0
    eye = np.eye(3)
    kf = KalmanFilter(eye, q_m2_per_s * dt * eye, eye, np.diag([sigma_h_m**2, sigma_h_m**2, sigma_v_m**2]),
                      np.zeros(3), 1e6 * eye).fit()
    smoothed = rts_smooth(kf.run(z[None]), eye).x[0]
    x, y, w = pymap3d.enu2uvw(smoothed[:, 0], smoothed[:, 1], smoothed[:, 2], lat, lon, deg=True)
    out = origin + np.stack([x, y, w], -1)
    return out
