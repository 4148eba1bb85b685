"""Atmospheric delays of the GPS L1 signal: the broadcast Klobuchar ionosphere and the Saastamoinen troposphere.

Klobuchar: IS-GPS-200 (rev. N) 20.3.3.5.2.5, Figure 20-4 (the user algorithm, angles in semicircles).
Saastamoinen (1972) with a standard atmosphere at the receiver height, as RTKLIB's ``tropmodel``.
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.gnss.geodesy import ecef_to_geodetic

def klobuchar_delay_s(alpha, beta, receiver_m, elevation_rad, azimuth_rad, gps_tow_s) -> np.ndarray:
    """L1 ionospheric delay (s) of the broadcast Klobuchar model, IS-GPS-200 20.3.3.5.2.5 (angles in
    semicircles inside, as the standard writes them). Arrays broadcast; ``gps_tow_s`` GPS time of week."""
    lat, lon, _ = ecef_to_geodetic(receiver_m)
    return klobuchar_delay_at_s(alpha, beta, lat, lon, elevation_rad, azimuth_rad, gps_tow_s)


def klobuchar_delay_at_s(alpha, beta, lat_rad, lon_rad, elevation_rad, azimuth_rad, gps_tow_s) -> np.ndarray:
    """:func:`klobuchar_delay_s` for receivers given by latitude and longitude (rad), arrays broadcast
    (e.g. one receiver position per epoch, shape (epochs, 1), against (epochs, sats) angles)."""
    lat, lon = np.asarray(lat_rad, dtype=np.float64), np.asarray(lon_rad, dtype=np.float64)
    el = elevation_rad / math.pi
    psi = 0.0137 / (el + 0.11) - 0.022
    phi_i = np.clip(lat / math.pi + psi * np.cos(azimuth_rad), -0.416, 0.416)
    lam_i = lon / math.pi + psi * np.sin(azimuth_rad) / np.cos(phi_i * math.pi)
    phi_m = phi_i + 0.064 * np.cos((lam_i - 1.617) * math.pi)
    t = np.mod(4.32e4 * lam_i + gps_tow_s, 86_400.0)
    amp = np.maximum(sum(a * phi_m**k for k, a in enumerate(alpha)), 0.0)
    per = np.maximum(sum(b * phi_m**k for k, b in enumerate(beta)), 72_000.0)
    x = 2.0 * math.pi * (t - 50_400.0) / per
    slant = 1.0 + 16.0 * (0.53 - el) ** 3
    day = 5e-9 + amp * (1.0 - x**2 / 2.0 + x**4 / 24.0)
    return slant * np.where(np.abs(x) < 1.57, day, 5e-9)


def saastamoinen_delay_m(receiver_m, elevation_rad, *, humidity: float = 0.7) -> np.ndarray:
    """Tropospheric delay (m): Saastamoinen (1972) with a standard atmosphere at the receiver height
    (pressure ``1013.25 (1 - 2.2557e-5 h)^5.2568`` hPa, temperature ``15 - 6.5e-3 h`` degC), as RTKLIB;
    zero outside heights -100 m .. 10 km (no atmosphere model there)."""
    lat, _, h = ecef_to_geodetic(receiver_m)
    return saastamoinen_delay_at_m(lat, h, elevation_rad, humidity=humidity)


def saastamoinen_delay_at_m(lat_rad, height_m, elevation_rad, *, humidity: float = 0.7) -> np.ndarray:
    """:func:`saastamoinen_delay_m` for receivers given by latitude (rad) and ellipsoidal height (m), arrays
    broadcast against the elevations; zero where the height is outside -100 m .. 10 km."""
    lat = np.asarray(lat_rad, dtype=np.float64)
    h_raw = np.asarray(height_m, dtype=np.float64)
    inside = (h_raw >= -100.0) & (h_raw <= 1e4)
    h = np.clip(h_raw, 0.0, 1e4)
    pressure = 1013.25 * (1.0 - 2.2557e-5 * h) ** 5.2568
    temp_k = 15.0 - 6.5e-3 * h + 273.16
    e = 6.108 * humidity * np.exp((17.15 * temp_k - 4684.0) / (temp_k - 38.45))
    cos_z = np.cos(math.pi / 2.0 - np.maximum(elevation_rad, 0.0))
    dry = 0.0022768 * pressure / (1.0 - 0.00266 * np.cos(2.0 * lat) - 0.00028 * h / 1e3) / cos_z
    wet = 0.002277 * (1255.0 / temp_k + 0.05) * e / cos_z
    return np.where(inside, dry + wet, 0.0)


__all__ = ["klobuchar_delay_s", "klobuchar_delay_at_s", "saastamoinen_delay_m", "saastamoinen_delay_at_m"]
