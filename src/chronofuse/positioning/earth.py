"""The WGS-84 Earth an inertial navigator needs: radii of curvature, rotation, normal gravity.

Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd ed. (2013):
meridian and transverse radii eqs. (2.105)-(2.106), Somigliana normal gravity on the ellipsoid eq. (2.134)
and its height dependence eq. (2.139). Latitudes in rad, heights in m above the ellipsoid.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "A_M",
    "FLATTENING",
    "E2",
    "B_M",
    "OMEGA_IE_RAD_PER_S",
    "MU_M3_PER_S2",
    "radii_of_curvature_m",
    "normal_gravity_m_per_s2",
    "earth_rate_ned",
    "transport_rate_ned",
    "schuler_rate_rad_per_s",
]

A_M = 6_378_137.0  # WGS-84 semi-major axis
FLATTENING = 1.0 / 298.257223563
E2 = FLATTENING * (2.0 - FLATTENING)
B_M = A_M * (1.0 - FLATTENING)
OMEGA_IE_RAD_PER_S = 7.292115e-5  # WGS-84 Earth rotation rate
MU_M3_PER_S2 = 3.986004418e14  # WGS-84 Earth gravitational constant
_G_EQUATOR = 9.7803253359  # normal gravity at the equator (Somigliana constants)
_G_K = 1.931853e-3


def radii_of_curvature_m(lat_rad):
    """Meridian ``R_N`` and transverse ``R_E`` radii of curvature (m) at geodetic latitude, Groves (2.105-6)."""
    s2 = np.sin(lat_rad) ** 2
    d = 1.0 - E2 * s2
    return A_M * (1.0 - E2) / d**1.5, A_M / np.sqrt(d)


def normal_gravity_m_per_s2(lat_rad, height_m):
    """Magnitude of normal (plumb-bob) gravity at latitude and height, Groves (2.134) and (2.139)."""
    s2 = np.sin(lat_rad) ** 2
    g0 = _G_EQUATOR * (1.0 + _G_K * s2) / np.sqrt(1.0 - E2 * s2)
    m = OMEGA_IE_RAD_PER_S**2 * A_M**2 * B_M / MU_M3_PER_S2
    return g0 * (1.0 - 2.0 / A_M * (1.0 + FLATTENING + m - 2.0 * FLATTENING * s2) * height_m
                 + 3.0 / A_M**2 * height_m**2)


def earth_rate_ned(lat_rad) -> np.ndarray:
    """Earth rotation in the local north-east-down frame, ``Omega [cos L, 0, -sin L]``, shape (..., 3)."""
    lat = np.asarray(lat_rad, dtype=np.float64)
    return OMEGA_IE_RAD_PER_S * np.stack([np.cos(lat), np.zeros_like(lat), -np.sin(lat)], axis=-1)


def transport_rate_ned(lat_rad, height_m, v_ned_m_per_s) -> np.ndarray:
    """Rotation of the NED frame as it moves over the ellipsoid, Groves (5.44), shape (..., 3)."""
    r_n, r_e = radii_of_curvature_m(lat_rad)
    v = np.asarray(v_ned_m_per_s, dtype=np.float64)
    ve = v[..., 1] / (r_e + height_m)
    return np.stack([ve, -v[..., 0] / (r_n + height_m), -ve * np.tan(lat_rad)], axis=-1)


def schuler_rate_rad_per_s(lat_rad=0.0, height_m=0.0) -> float:
    """Schuler angular frequency ``sqrt(g / R)`` (period ~84.4 min at the surface), with ``R = sqrt(R_N R_E)``."""
    r_n, r_e = radii_of_curvature_m(lat_rad)
    return float(np.sqrt(normal_gravity_m_per_s2(lat_rad, height_m) / (np.sqrt(r_n * r_e) + height_m)))
