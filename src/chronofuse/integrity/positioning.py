"""Signal corrections and single-point positioning for a static GPS receiver.

Receiver geodesy (WGS 84), satellite elevation and azimuth, the Klobuchar ionosphere (IS-GPS-200
20.3.3.5.2.5), the Saastamoinen troposphere with a standard atmosphere (Saastamoinen 1972, as RTKLIB's
``tropmodel``), pseudoranges corrected for them and for the satellite clock, and a least-squares
single-point position from them (used to check the broadcast-ephemeris module against the RINEX header
positions, and by :mod:`chronofuse.integrity.identification` for the channel clock biases).
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.integrity.ephemeris import BroadcastEphemeris, geometry_from_pseudorange, select_ephemeris
from chronofuse.timescale import NS_PER_S, SECONDS_PER_WEEK

# WGS 84 ellipsoid
_A_M = 6_378_137.0
_F = 1.0 / 298.257223563
_E2 = _F * (2.0 - _F)



# ---------------------------------------------------------------------------------------------------------
# Receiver geometry and atmosphere
# ---------------------------------------------------------------------------------------------------------


def ecef_to_geodetic(position_m) -> tuple[float, float, float]:
    """WGS 84 latitude (rad), longitude (rad), ellipsoidal height (m) of an ECEF point (Bowring iteration)."""
    x, y, z = (float(v) for v in position_m)
    lon = math.atan2(y, x)
    p = math.hypot(x, y)
    lat = math.atan2(z, p * (1.0 - _E2))
    h = 0.0
    for _ in range(8):
        n = _A_M / math.sqrt(1.0 - _E2 * math.sin(lat) ** 2)
        h = p / math.cos(lat) - n
        lat = math.atan2(z, p * (1.0 - _E2 * n / (n + h)))
    return lat, lon, h


def elevation_azimuth(receiver_m, satellite_m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Elevation and azimuth (rad) of ``satellite_m`` (..., 3) seen from ``receiver_m`` (3,) (local ENU)."""
    lat, lon, _ = ecef_to_geodetic(receiver_m)
    d = satellite_m - np.asarray(receiver_m, dtype=np.float64)
    sl, cl, sp, cp = math.sin(lon), math.cos(lon), math.sin(lat), math.cos(lat)
    e = -sl * d[..., 0] + cl * d[..., 1]
    n = -sp * cl * d[..., 0] - sp * sl * d[..., 1] + cp * d[..., 2]
    u = cp * cl * d[..., 0] + cp * sl * d[..., 1] + sp * d[..., 2]
    return np.arctan2(u, np.hypot(e, n)), np.mod(np.arctan2(e, n), 2.0 * math.pi)


def klobuchar_delay_s(alpha, beta, receiver_m, elevation_rad, azimuth_rad, gps_tow_s) -> np.ndarray:
    """L1 ionospheric delay (s) of the broadcast Klobuchar model, IS-GPS-200 20.3.3.5.2.5 (angles in
    semicircles inside, as the standard writes them). Arrays broadcast; ``gps_tow_s`` GPS time of week."""
    lat, lon, _ = ecef_to_geodetic(receiver_m)
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
    if not -100.0 <= h <= 1e4:
        return np.zeros(np.shape(elevation_rad))
    h = max(h, 0.0)
    pressure = 1013.25 * (1.0 - 2.2557e-5 * h) ** 5.2568
    temp_k = 15.0 - 6.5e-3 * h + 273.16
    e = 6.108 * humidity * math.exp((17.15 * temp_k - 4684.0) / (temp_k - 38.45))
    cos_z = np.cos(math.pi / 2.0 - np.maximum(elevation_rad, 0.0))
    dry = 0.0022768 * pressure / (1.0 - 0.00266 * math.cos(2.0 * lat) - 0.00028 * h / 1e3) / cos_z
    wet = 0.002277 * (1255.0 / temp_k + 0.05) * e / cos_z
    return dry + wet


def _tow_s(gps_ns: np.ndarray) -> np.ndarray:
    return np.mod(gps_ns, SECONDS_PER_WEEK * NS_PER_S) / NS_PER_S


def corrected_ranges(eph, gps_ns, pseudorange_m, receiver_m, alpha, beta, elevation_mask_rad):
    """``(rho - |r_sat - r_rx| + c dt_sat - I - T)`` (m), shape (epochs, sats), NaN below the mask or
    without ephemeris; with the elevation (rad). ``alpha``/``beta`` None: no ionosphere correction."""
    geo = geometry_from_pseudorange(eph, gps_ns, pseudorange_m, receiver_m)
    el, az = elevation_azimuth(receiver_m, geo.satellite_m)
    iono_m = 0.0
    if alpha is not None and beta is not None:
        iono_m = SPEED_OF_LIGHT_M_PER_S * klobuchar_delay_s(alpha, beta, receiver_m, el, az, _tow_s(gps_ns)[:, None])
    tropo_m = saastamoinen_delay_m(receiver_m, el)
    out = pseudorange_m - geo.range_m + SPEED_OF_LIGHT_M_PER_S * geo.clock_s - iono_m - tropo_m
    out = np.where(eph.valid & (el >= elevation_mask_rad), out, np.nan)
    return out, el


def single_point_position(obs, nav, *, elevation_mask_deg: float = 10.0, iterations: int = 8):
    """Least-squares single-point position per epoch from L1 pseudoranges (a check of the channel model).

    Unknowns ``(x, y, z, c dt_rx)``; starts at the Earth's centre, applies the atmosphere once the position
    is within 100 km of the surface. Returns ``(positions_m (epochs, 3), clock_bias_s (epochs,), n_used (epochs,))``;
    NaN rows where fewer than four satellites are usable.
    """
    sats = obs.satellites
    eph = select_ephemeris(nav, sats, obs.gps_ns)
    epochs = obs.gps_ns.size
    pos = np.full((epochs, 3), np.nan)
    clk = np.full(epochs, np.nan)
    used = np.zeros(epochs, dtype=np.int64)
    mask = math.radians(elevation_mask_deg)
    for k in range(epochs):
        sel = slice(k, k + 1)
        sub = _subset(eph, sel)
        rho = obs.pseudorange_m[sel]
        x = np.zeros(4)
        ok = np.zeros(len(sats), dtype=bool)
        for it in range(iterations):
            near = np.linalg.norm(x[:3]) > 1e6 and abs(ecef_to_geodetic(x[:3])[2]) < 1e5
            geo = geometry_from_pseudorange(sub, obs.gps_ns[sel], rho, x[:3])
            if near:
                res, el = corrected_ranges(sub, obs.gps_ns[sel], rho, x[:3], nav.klobuchar_alpha, nav.klobuchar_beta,
                                           mask)
                res = res[0]
            else:
                res = (rho - geo.range_m + SPEED_OF_LIGHT_M_PER_S * geo.clock_s)[0]
                res = np.where(sub.valid[0], res, np.nan)
            ok = np.isfinite(res)
            if ok.sum() < 4:
                break
            los = (geo.satellite_m[0, ok] - x[:3]) / geo.range_m[0, ok, None]
            g = np.column_stack([-los, np.ones(ok.sum())])
            dx, *_ = np.linalg.lstsq(g, res[ok] - x[3], rcond=None)
            x = x + dx
        if ok.sum() >= 4:
            pos[k], clk[k], used[k] = x[:3], x[3] / SPEED_OF_LIGHT_M_PER_S, int(ok.sum())
    return pos, clk, used


def _subset(eph: BroadcastEphemeris, rows) -> BroadcastEphemeris:
    return BroadcastEphemeris(
        params={k: v[rows] for k, v in eph.params.items()},
        toe_gps_ns=eph.toe_gps_ns[rows],
        toc_gps_ns=eph.toc_gps_ns[rows],
        valid=eph.valid[rows],
    )


__all__ = [
    "corrected_ranges",
    "ecef_to_geodetic",
    "elevation_azimuth",
    "klobuchar_delay_s",
    "saastamoinen_delay_m",
    "single_point_position",
]
