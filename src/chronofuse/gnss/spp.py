"""Least-squares single-point position of a GPS receiver from L1 pseudoranges and the broadcast ephemeris.

Per epoch, Gauss-Newton on ``rho_n = |r_sat,n - r| + c dt_rx - c dt_sat,n + I_n + T_n`` for the unknowns
``(x, y, z, c dt_rx)`` with the line-of-sight design matrix ``G_n = (-(r_sat,n - r) / |r_sat,n - r|, 1)``
(Misra & Enge, GPS: Signals, Measurements and Performance, 2nd ed., section 6.1.1). Used to check the
signal models against surveyed positions (the RINEX headers' ``APPROX POSITION XYZ``) and the channel clock
biases of :mod:`chronofuse.gnss.observables` against an independent receiver clock estimate.
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.ephemeris import GpsNavigation, geometry_from_pseudorange, select_ephemeris
from chronofuse.gnss.geodesy import ecef_to_geodetic
from chronofuse.gnss.observables import corrected_ranges


def single_point_position(obs, nav: GpsNavigation, *, elevation_mask_deg: float = 10.0, iterations: int = 8):
    """Least-squares single-point position per epoch from L1 pseudoranges (a check of the channel model).

    ``obs`` holds ``satellites`` (sats,), ``gps_ns`` (int64 (epochs,)) and ``pseudorange_m`` (epochs, sats)
    (a :class:`chronofuse.io.rinex.GpsObservations`). Unknowns ``(x, y, z, c dt_rx)``; starts at the Earth's
    centre, applies the atmosphere once the position is within 100 km of the surface. Returns ``(positions_m (epochs, 3), clock_bias_s (epochs,), n_used (epochs,))``;
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
        sub = eph.epochs(sel)
        rho = obs.pseudorange_m[sel]
        x = np.zeros(4)
        ok = np.zeros(len(sats), dtype=bool)
        for _ in range(iterations):
            near = np.linalg.norm(x[:3]) > 1e6 and abs(ecef_to_geodetic(x[:3])[2]) < 1e5
            geo = geometry_from_pseudorange(sub, obs.gps_ns[sel], rho, x[:3])
            if near:
                res, _ = corrected_ranges(sub, obs.gps_ns[sel], rho, x[:3], nav.klobuchar_alpha, nav.klobuchar_beta,
                                          mask, geometry=geo)
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


__all__ = ["single_point_position"]
