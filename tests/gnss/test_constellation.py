"""The GPS and BDS constellation models: orbit radii, periods, GEO stations and how many are in view."""

from __future__ import annotations

import math

import numpy as np
import pymap3d

from chronofuse.gnss.constellation import MU_GPS_M3_PER_S2, constellation, satellite_positions_ecef


def _visible(positions: np.ndarray, lat_deg: float, lon_deg: float, mask_deg: float = 10.0) -> np.ndarray:
    rx = np.array(pymap3d.geodetic2ecef(lat_deg, lon_deg, 0.0))
    d = positions - rx
    e, n, u = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat_deg, lon_deg)
    return np.degrees(np.arctan2(u, np.hypot(e, n))) > mask_deg


def test_gps_orbits_repeat_every_half_sidereal_day():
    gps = constellation("gps")
    period = 2 * math.pi * math.sqrt(gps.semi_major_axis_m[0] ** 3 / MU_GPS_M3_PER_S2)
    assert abs(period - 86164.0905 / 2) < 10.0
    pos = satellite_positions_ecef(gps, np.array([0.0, 86164.0905]))
    # After one sidereal day the ground track repeats (two orbits while the Earth turns once).
    assert np.abs(pos[1] - pos[0]).max() < 20e3


def test_bds_geo_satellites_hang_over_their_longitudes():
    bds = constellation("bds")
    pos = satellite_positions_ecef(bds, np.linspace(0, 86400, 25))
    geo = [bds.ids.index(k) for k in ("C59", "C60", "C61")]
    lon = np.degrees(np.arctan2(pos[:, geo, 1], pos[:, geo, 0]))
    assert np.allclose(lon, [80.0, 110.5, 140.0], atol=0.1)
    assert np.abs(pos[:, geo, 2]).max() < 1.0


def test_every_satellite_stays_on_its_circular_orbit():
    for system in ("gps", "bds"):
        con = constellation(system)
        r = np.linalg.norm(satellite_positions_ecef(con, np.linspace(0, 43200, 13)), axis=-1)
        assert np.allclose(r, con.semi_major_axis_m, rtol=1e-12)


def test_a_mid_latitude_receiver_sees_what_the_real_systems_offer():
    t = np.arange(0.0, 86400.0, 600.0)
    gps = _visible(satellite_positions_ecef(constellation("gps"), t), 30.5, 114.3).sum(axis=1)
    bds = _visible(satellite_positions_ecef(constellation("bds"), t), 30.5, 114.3).sum(axis=1)
    # The 24-slot GPS keeps 5-8 above 10 deg (a position fix at all times); BDS-3 over China (GEO + IGSO +
    # MEO) offers several more.
    assert 5 <= gps.min() and gps.max() <= 12 and 6 <= gps.mean() <= 9
    assert bds.mean() > gps.mean() + 2
