"""WGS 84 geodesy through pymap3d, checked against the ellipsoid's definition and an independent iteration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.gnss.geodesy import ecef_to_geodetic, elevation_azimuth, geodetic_to_ecef

A_M = 6_378_137.0  # WGS 84 semi-major axis (NIMA TR8350.2 Table 3.1)
F = 1.0 / 298.257223563  # WGS 84 flattening
E2 = F * (2.0 - F)
B_M = A_M * (1.0 - F)

# APPROX POSITION XYZ of the two RTKLIB Trimble 5700 stations (GSI, Japan)
STATIONS_M = {"0759": (-3976219.5082, 3382372.5671, 3652512.9849), "3040": (-3978242.4348, 3382841.1715, 3649902.7667)}


def _textbook_ecef(lat, lon, h):
    """NIMA TR8350.2 eq. 4-14, written out here."""
    n = A_M / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
    return np.array([(n + h) * math.cos(lat) * math.cos(lon), (n + h) * math.cos(lat) * math.sin(lon),
                     (n * (1.0 - E2) + h) * math.sin(lat)])


def _bowring(position_m):
    """Latitude, longitude, height by fixed-point iteration on ``tan(lat) = z / (p (1 - e^2 N / (N + h)))``."""
    x, y, z = position_m
    p = math.hypot(x, y)
    lat, h = math.atan2(z, p * (1.0 - E2)), 0.0
    for _ in range(10):
        n = A_M / math.sqrt(1.0 - E2 * math.sin(lat) ** 2)
        h = p / math.cos(lat) - n
        lat = math.atan2(z, p * (1.0 - E2 * n / (n + h)))
    return lat, math.atan2(y, x), h


def test_the_ellipsoid_axes_are_at_zero_height():
    np.testing.assert_allclose(ecef_to_geodetic([A_M, 0.0, 0.0]), (0.0, 0.0, 0.0), atol=1e-9)
    np.testing.assert_allclose(ecef_to_geodetic([0.0, A_M, 0.0]), (0.0, math.pi / 2, 0.0), atol=1e-9)
    lat, _, h = ecef_to_geodetic([0.0, 0.0, B_M])
    assert lat == pytest.approx(math.pi / 2, abs=1e-12) and h == pytest.approx(0.0, abs=1e-6)
    lat, _, h = ecef_to_geodetic([0.0, 0.0, -B_M - 100.0])
    assert lat == pytest.approx(-math.pi / 2, abs=1e-12) and h == pytest.approx(100.0, abs=1e-6)


@pytest.mark.parametrize("lat_deg,lon_deg,h_m", [(45.0, -120.0, 1000.0), (-33.9, 18.4, 0.0), (89.0, 10.0, -50.0),
                                                  (10.0, 179.9, 9000.0)])
def test_geodetic_round_trip_matches_the_textbook_formula(lat_deg, lon_deg, h_m):
    lat, lon = math.radians(lat_deg), math.radians(lon_deg)
    ecef = _textbook_ecef(lat, lon, h_m)
    np.testing.assert_allclose(geodetic_to_ecef(lat, lon, h_m), ecef, rtol=0, atol=1e-6)
    got = ecef_to_geodetic(ecef)
    np.testing.assert_allclose(got[:2], (lat, lon), rtol=0, atol=1e-14)
    assert got[2] == pytest.approx(h_m, abs=1e-6)


@pytest.mark.parametrize("station", sorted(STATIONS_M))
def test_station_geodetic_coordinates_agree_with_an_independent_iteration(station):
    got = ecef_to_geodetic(STATIONS_M[station])
    ref = _bowring(STATIONS_M[station])
    np.testing.assert_allclose(got[:2], ref[:2], rtol=0, atol=1e-13)
    assert got[2] == pytest.approx(ref[2], abs=1e-6)
    # both stations are near Tokyo, a few tens of metres above the ellipsoid
    assert 35.0 < math.degrees(got[0]) < 36.0 and 139.0 < math.degrees(got[1]) < 140.0 and 0 < got[2] < 200


def test_elevation_and_azimuth_of_hand_placed_points():
    # on the equator at longitude 0 the local frame is east = +y, north = +z, up = +x
    rx = np.array([A_M, 0.0, 0.0])
    d = 20_000e3
    points = np.array([rx + [d, 0, 0], rx + [0, 0, d], rx + [0, d, 0], rx + [0, -d, 0], rx + [d, 0, d],
                       rx + [0, 0, -d]])
    el, az = elevation_azimuth(rx, points)
    np.testing.assert_allclose(el, [math.pi / 2, 0.0, 0.0, 0.0, math.pi / 4, 0.0], atol=1e-12)
    np.testing.assert_allclose(az[1:], [0.0, math.pi / 2, 3 * math.pi / 2, 0.0, math.pi], atol=1e-12)


def test_the_ellipsoid_normal_points_to_the_zenith_anywhere():
    lat, lon = math.radians(35.6), math.radians(139.5)
    rx = geodetic_to_ecef(lat, lon, 50.0)
    above = geodetic_to_ecef(lat, lon, 20_000e3)
    el, _ = elevation_azimuth(rx, above[None, :])
    assert el[0] == pytest.approx(math.pi / 2, abs=1e-9)
