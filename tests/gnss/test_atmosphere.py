"""Klobuchar (IS-GPS-200 20.3.3.5.2.5) and Saastamoinen delays against the standard's closed cases and ISA tables."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.gnss.atmosphere import klobuchar_delay_s, saastamoinen_delay_m
from chronofuse.gnss.geodesy import geodetic_to_ecef

EQUATOR_M = geodetic_to_ecef(0.0, 0.0, 0.0)
ALPHA = (2e-8, 0.0, 0.0, 0.0)
BETA = (1.2e5, 0.0, 0.0, 0.0)
ZENITH_OBLIQUITY = 1.0 + 16.0 * (0.53 - 0.5) ** 3  # F at E = 0.5 semicircles


def test_klobuchar_night_delay_is_the_5_ns_floor_times_the_obliquity():
    # longitude 0, GPS time of week 0: local midnight, far outside the cosine's half period
    delay = klobuchar_delay_s(ALPHA, BETA, EQUATOR_M, np.array([math.pi / 2]), np.array([0.0]), 0.0)
    assert delay[0] == pytest.approx(ZENITH_OBLIQUITY * 5e-9, rel=1e-12)
    # at the horizon the obliquity factor is 1 + 16 * 0.53^3
    horizon = klobuchar_delay_s(ALPHA, BETA, EQUATOR_M, np.array([0.0]), np.array([0.0]), 0.0)
    assert horizon[0] == pytest.approx((1.0 + 16.0 * 0.53**3) * 5e-9, rel=1e-12)


def test_klobuchar_peak_at_14h_local_is_floor_plus_amplitude():
    # zenith at longitude 0: the pierce point is overhead, local time 14:00 = 50,400 s of the day, x = 0
    delay = klobuchar_delay_s(ALPHA, BETA, EQUATOR_M, np.array([math.pi / 2]), np.array([0.0]), 50_400.0)
    # amplitude alpha_0 + alpha_1 phi_m + ...: with only alpha_0 it is alpha_0 whatever the magnetic latitude
    assert delay[0] == pytest.approx(ZENITH_OBLIQUITY * (5e-9 + ALPHA[0]), rel=1e-12)


def test_saastamoinen_zenith_hydrostatic_delay_follows_the_standard_atmosphere_pressure():
    # dry air only (humidity 0): 2.2768 mm/hPa x surface pressure / (1 - 0.00266 cos 2 lat - 0.00028 h_km)
    # (Saastamoinen 1972; Davis et al. 1985), with the pressures of the US Standard Atmosphere 1976 table:
    # 1013.25 hPa at sea level, 898.76 hPa at 1000 m
    for height_m, pressure_hpa in ((0.0, 1013.25), (1000.0, 898.76)):
        rx = geodetic_to_ecef(0.0, 0.0, height_m)
        zenith = saastamoinen_delay_m(rx, np.array([math.pi / 2]), humidity=0.0)[0]
        expected = 2.2768e-3 * pressure_hpa / (1.0 - 0.00266 - 0.00028 * height_m / 1e3)
        assert zenith == pytest.approx(expected, abs=1e-4)


def test_saastamoinen_slant_delay_is_the_zenith_delay_over_sine_elevation():
    el = np.radians([90.0, 30.0, 10.0])
    delay = saastamoinen_delay_m(EQUATOR_M, el)
    np.testing.assert_allclose(delay / delay[0], 1.0 / np.sin(el), rtol=1e-12)
    # about 2.4 m at the zenith at sea level with 70 % humidity (2.31 m dry)
    assert 2.35 < delay[0] < 2.5


def test_saastamoinen_is_zero_where_no_atmosphere_model_holds():
    above = geodetic_to_ecef(0.3, 1.0, 20e3)
    assert np.all(saastamoinen_delay_m(above, np.radians([90.0, 20.0])) == 0.0)
