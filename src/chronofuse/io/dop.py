"""Dilution of precision from satellite geometry: GDOP, TDOP and PDOP of satellites seen at (elevation,
azimuth), for receivers that send no GDOP or TDOP (NMEA GSA carries only PDOP/HDOP/VDOP; used by
:mod:`chronofuse.io.nmea`)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["geometry_dops", "dop_cofactor"]


def dop_cofactor(elev_az_deg) -> np.ndarray | None:
    """``G = (H^T H)^-1`` (4, 4) of satellites at (elevation, azimuth) in degrees, one receiver clock,
    rows ``H_i = [cos e sin a, cos e cos a, sin e, 1]`` (east, north, up, clock); None with fewer than 4
    satellites or a singular geometry."""
    if len(elev_az_deg) < 4:
        return None
    ea = np.radians(np.asarray(elev_az_deg, dtype=np.float64))
    el, az = ea[:, 0], ea[:, 1]
    h = np.column_stack((np.cos(el) * np.sin(az), np.cos(el) * np.cos(az), np.sin(el), np.ones(el.size)))
    try:
        return np.linalg.inv(h.T @ h)
    except np.linalg.LinAlgError:
        return None


def geometry_dops(elev_az_deg) -> tuple[float, float, float]:
    """GDOP and TDOP of satellites at (elevation, azimuth) in degrees, one receiver clock:
    ``G = (H^T H)^-1`` with rows ``H_i = [cos e sin a, cos e cos a, sin e, 1]``, ``GDOP = sqrt(tr G)``,
    ``TDOP = sqrt(G_44)``, ``PDOP = sqrt(G_11 + G_22 + G_33)`` (Misra & Enge, *Global Positioning
    System*, 2nd ed., section 6.1.3; gpsd's ``fill_dop`` does the same for receivers that send no GDOP).
    Returns (GDOP, TDOP, PDOP); NaN with fewer than 4 satellites or a singular geometry."""
    g = dop_cofactor(elev_az_deg)
    if g is None:
        return math.nan, math.nan, math.nan
    tr, g44 = float(np.trace(g)), float(g[3, 3])
    if not (tr > 0 and 0 < g44 < tr):
        return math.nan, math.nan, math.nan
    return math.sqrt(tr), math.sqrt(g44), math.sqrt(tr - g44)
