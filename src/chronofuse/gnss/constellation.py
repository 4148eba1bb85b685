"""Documented constellation models of GPS and BeiDou: circular orbits in the nominal geometry.

For simulation where no broadcast ephemeris is given (real navigation files go through
:mod:`chronofuse.gnss.ephemeris`). Orbits are circular Keplerian, positions in ECEF (WGS-84 rotation rate),
time ``t_s`` in seconds from the scenario start, when ECI and ECEF coincide:

* **GPS**: the nominal 24-slot constellation as a Walker 24/6/1 delta pattern (6 planes 60 deg apart in
  right ascension, 4 satellites each, inclination 55 deg, period half a sidereal day (26,562 km);
  the GPS SPS Performance Standard (2020), section 3.2, gives 6 planes at 55 deg and 24 slots).
* **BDS-3**: 24 MEO as a Walker 24/3/1 pattern (inclination 55 deg, semi-major axis 27,906.1 km), 3 GEO at
  80, 110.5 and 140 deg E, and 3 IGSO (inclination 55 deg, geosynchronous, one ground track crossing the
  equator at 118 deg E, 120 deg apart in argument of latitude), as the BeiDou Open Service Performance
  Standard (CSNO, 2021), section 2, describes the BDS-3 constellation.

A Walker ``T/P/F`` pattern puts satellite ``s`` of plane ``p`` at right ascension ``360 p / P`` and argument of
latitude ``360 s / (T/P) + 360 F p / T`` degrees (Walker 1984).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from chronofuse.validation import check_array, check_choice

__all__ = ["Constellation", "CONSTELLATIONS", "constellation", "walker", "satellite_positions_ecef",
           "MU_GPS_M3_PER_S2", "OMEGA_E_RAD_PER_S"]

MU_GPS_M3_PER_S2 = 3.986005e14  # IS-GPS-200 value of GM
OMEGA_E_RAD_PER_S = 7.2921151467e-5  # WGS-84 rotation rate
SIDEREAL_DAY_S = 86_164.0905


def _semi_major_axis_m(period_s: float) -> float:
    """Kepler's third law: the circular orbit of the given period."""
    return (MU_GPS_M3_PER_S2 * (period_s / (2 * math.pi)) ** 2) ** (1.0 / 3.0)


_GEO_A_M = _semi_major_axis_m(SIDEREAL_DAY_S)  # 42,164 km


@dataclass(frozen=True)
class Constellation:
    """Circular orbits of one system: per satellite ``semi_major_axis_m``, ``inclination_rad``, ``raan_rad``
    (right ascension of the node at t = 0) and ``arg_latitude_rad`` (at t = 0), each of shape (n,); ``ids``
    are RINEX-style names ("G01", "C19")."""

    system: str
    ids: tuple[str, ...]
    semi_major_axis_m: np.ndarray
    inclination_rad: np.ndarray
    raan_rad: np.ndarray
    arg_latitude_rad: np.ndarray

    def __len__(self) -> int:
        return len(self.ids)


def walker(total: int, planes: int, phasing: int, semi_major_axis_m: float, inclination_deg: float):
    """Semi-major axes, inclinations, right ascensions and arguments of latitude (each (total,), rad) of a
    Walker ``total/planes/phasing`` pattern."""
    per_plane = total // planes
    p = np.repeat(np.arange(planes), per_plane)
    s = np.tile(np.arange(per_plane), planes)
    raan = 2 * math.pi * p / planes
    u = 2 * math.pi * s / per_plane + 2 * math.pi * phasing * p / total
    return np.full(total, semi_major_axis_m), np.full(total, math.radians(inclination_deg)), raan, u


def _gps() -> Constellation:
    a, i, raan, u = walker(24, 6, 1, _semi_major_axis_m(SIDEREAL_DAY_S / 2), 55.0)  # 26,562 km
    return Constellation("gps", tuple(f"G{k + 1:02d}" for k in range(24)), a, i, raan, u)


def _bds() -> Constellation:
    a, i, raan, u = walker(24, 3, 1, 27_906_100.0, 55.0)
    geo_lon = np.radians([80.0, 110.5, 140.0])
    igso_u = np.radians([0.0, 120.0, 240.0])
    n_geo = math.sqrt(MU_GPS_M3_PER_S2 / _GEO_A_M**3)
    # An IGSO's node sits at 118 deg E when its argument of latitude is zero, i.e. at t = -u0 / n.
    igso_raan = math.radians(118.0) - OMEGA_E_RAD_PER_S * igso_u / n_geo
    a = np.concatenate([a, np.full(6, _GEO_A_M)])
    i = np.concatenate([i, np.zeros(3), np.full(3, math.radians(55.0))])
    raan = np.concatenate([raan, np.zeros(3), igso_raan])
    u = np.concatenate([u, geo_lon, igso_u])
    # BDS-3 PRNs: MEO 19-30, 32-37, 41-46; GEO 59-61; IGSO 38-40.
    meo = [19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29, 30, 32, 33, 34, 35, 36, 37, 41, 42, 43, 44, 45, 46]
    ids = tuple(f"C{k:02d}" for k in meo) + ("C59", "C60", "C61", "C38", "C39", "C40")
    return Constellation("bds", ids, a, i, raan, u)


CONSTELLATIONS: dict[str, Constellation] = {"gps": _gps(), "bds": _bds()}


def constellation(system: str) -> Constellation:
    """The model of ``system`` ("gps" or "bds")."""
    check_choice(system, "system", CONSTELLATIONS)
    return CONSTELLATIONS[system]


def satellite_positions_ecef(con: Constellation, t_s) -> np.ndarray:
    """ECEF positions (m) of every satellite at times ``t_s`` (k,): shape (k, n, 3).

    In the frame of the node, ``[a cos u, a sin u cos i, a sin u sin i]`` with ``u = u0 + n t`` and
    ``n = sqrt(mu / a^3)``, turned about z by the node's longitude ``raan - omega_e t`` (the Earth turns
    under the inertial node). A GEO (inclination 0, a sidereal-day orbit) stays over its longitude.
    """
    t = check_array(t_s, "t_s", ndim=1)[:, None]
    n = np.sqrt(MU_GPS_M3_PER_S2 / con.semi_major_axis_m**3)
    u = con.arg_latitude_rad + n * t
    cu, su = np.cos(u), np.sin(u)
    ci, si = np.cos(con.inclination_rad), np.sin(con.inclination_rad)
    lon_node = con.raan_rad - OMEGA_E_RAD_PER_S * t
    co, so = np.cos(lon_node), np.sin(lon_node)
    a = con.semi_major_axis_m
    return np.stack([a * (cu * co - su * ci * so), a * (cu * so + su * ci * co), a * su * si], axis=-1)
