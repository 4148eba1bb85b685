"""Receiver geodesy on the WGS 84 ellipsoid, through pymap3d.

ECEF <-> geodetic (latitude, longitude, ellipsoidal height) and a satellite's elevation and azimuth in the
receiver's local east-north-up frame. pymap3d converts ECEF to geodetic in closed form (You 2000,
J. Surv. Eng. 126(1)) and geodetic to ECEF by ``x = (N + h) cos(lat) cos(lon)``, ``y = (N + h) cos(lat)
sin(lon)``, ``z = (N (1 - e^2) + h) sin(lat)``, ``N = a / sqrt(1 - e^2 sin^2 lat)`` (NIMA TR8350.2 eq. 4-14).
The local frame is ``e = -sin(lon) dx + cos(lon) dy``, ``n = -sin(lat) t + cos(lat) dz``, ``u = cos(lat) t +
sin(lat) dz`` with ``t = cos(lon) dx + sin(lon) dy``; elevation ``atan2(u, hypot(e, n))``, azimuth
``atan2(e, n)`` from north through east.

Accuracy (measured against a converged fixed-point iteration): within 100 km of the ellipsoid the closed
form is exact to 1e-15 rad and 3e-9 m; it degrades with height (1.2e-9 rad at 1000 km, 1.2e-6 rad at GPS
orbit height), so it is used here for receivers, never for satellites.
"""

from __future__ import annotations

import numpy as np
import pymap3d

_WGS84 = pymap3d.Ellipsoid.from_name("wgs84")


def ecef_to_geodetic(position_m) -> tuple[float, float, float]:
    """WGS 84 latitude (rad), longitude (rad) and ellipsoidal height (m) of one ECEF point ``position_m`` (3,)."""
    x, y, z = (float(v) for v in position_m)
    lat, lon, h = pymap3d.ecef2geodetic(x, y, z, _WGS84, deg=False)
    return float(lat), float(lon), float(h)


def geodetic_to_ecef(lat_rad: float, lon_rad: float, height_m: float) -> np.ndarray:
    """ECEF position (m), shape (3,), of a WGS 84 latitude (rad), longitude (rad) and ellipsoidal height (m)."""
    return np.array(pymap3d.geodetic2ecef(lat_rad, lon_rad, height_m, _WGS84, deg=False), dtype=np.float64)


def elevation_azimuth(receiver_m, satellite_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Elevation and azimuth (rad, azimuth in [0, 2 pi)) of ``satellite_m`` (..., 3) seen from ``receiver_m`` (3,)."""
    lat, lon, _ = ecef_to_geodetic(receiver_m)
    d = np.asarray(satellite_m, dtype=np.float64) - np.asarray(receiver_m, dtype=np.float64)
    east, north, up = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat, lon, deg=False)
    azimuth, elevation, _ = pymap3d.enu2aer(east, north, up, deg=False)
    return elevation, azimuth


__all__ = ["ecef_to_geodetic", "elevation_azimuth", "geodetic_to_ecef"]
