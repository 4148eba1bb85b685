"""Broadcast ephemeris (IS-GPS-200 Table 20-IV): physics checks on the real navigation files."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.ephemeris import (
    GM_M3_PER_S2,
    OMEGA_EARTH_RAD_PER_S,
    geometry_from_light_time,
    geometry_from_pseudorange,
    satellite_clock_s,
    satellite_position_ecef,
    select_ephemeris,
)


@pytest.fixture(scope="module")
def hour(rtklib):
    obs, nav = rtklib["07590920"]
    sats = sorted(set(nav.satellites))
    t = obs.gps_ns[0] + np.arange(0, 3600, 10, dtype=np.int64) * 1_000_000_000
    return nav, sats, t, select_ephemeris(nav, sats, t)


def test_orbit_radius_stays_between_perigee_and_apogee(hour):
    nav, sats, t, eph = hour
    r = np.linalg.norm(satellite_position_ecef(eph, t), axis=-1)
    a = eph.params["sqrt_a_sqrt_m"] ** 2
    e = eph.params["eccentricity"]
    ok = eph.valid
    assert ok.all(axis=0).sum() >= 15  # satellites with a healthy record within 4 h all the hour
    assert np.all(r[ok] > a[ok] * (1 - e[ok]) - 2e3) and np.all(r[ok] < a[ok] * (1 + e[ok]) + 2e3)
    assert abs(np.median(r[ok]) - 26_560e3) < 200e3


def test_inertial_speed_from_finite_differences_obeys_vis_viva(hour):
    nav, sats, t, eph = hour
    dt_s = 0.5
    p0 = satellite_position_ecef(eph, t, -dt_s)
    p1 = satellite_position_ecef(eph, t, dt_s)
    v_ecef = (p1 - p0) / (2 * dt_s)
    r = satellite_position_ecef(eph, t)
    omega = np.array([0.0, 0.0, OMEGA_EARTH_RAD_PER_S])
    v_inertial = v_ecef + np.cross(omega, r)
    speed = np.linalg.norm(v_inertial, axis=-1)[eph.valid]
    a = (eph.params["sqrt_a_sqrt_m"] ** 2)[eph.valid]
    rn = np.linalg.norm(r, axis=-1)[eph.valid]
    vis_viva = np.sqrt(GM_M3_PER_S2 * (2.0 / rn - 1.0 / a))
    # the harmonic corrections and J2 perturb the Kepler speed by well under 0.1 %
    np.testing.assert_allclose(speed, vis_viva, rtol=1e-3)
    assert 3.8e3 < np.median(speed) < 3.95e3


def test_satellite_clock_has_broadcast_magnitude_and_relativistic_term(hour):
    nav, sats, t, eph = hour
    clock = satellite_clock_s(eph, t)[eph.valid]
    assert np.all(np.abs(clock) < 1e-3)
    no_tgd = satellite_clock_s(eph, t, l1_tgd=False)
    np.testing.assert_allclose(no_tgd - satellite_clock_s(eph, t), eph.params["tgd_s"], atol=1e-18)
    # relativistic term: F e sqrt(A) sin E, at most ~45 ns for e = 0.02
    p = eph.params
    dt = (t[:, None] - eph.toc_gps_ns) / 1e9
    poly = p["af0_s"] + p["af1_s_per_s"] * dt + p["af2_s_per_s2"] * dt**2
    rel = (no_tgd - poly)[eph.valid]
    bound = 4.442807633e-10 * p["eccentricity"] * p["sqrt_a_sqrt_m"]
    assert np.all(np.abs(rel) <= bound[eph.valid] * (1 + 1e-9))
    assert np.abs(rel).max() > 1e-9


def test_light_time_and_pseudorange_emission_times_agree(rtklib):
    obs, nav = rtklib["30400920"]
    eph = select_ephemeris(nav, obs.satellites, obs.gps_ns)
    rx = obs.approx_position_m
    light = geometry_from_light_time(eph, obs.gps_ns, rx)
    # a receiver with a perfect clock would measure rho = range - c dt_sat
    rho = light.range_m - SPEED_OF_LIGHT_M_PER_S * light.clock_s
    from_rho = geometry_from_pseudorange(eph, obs.gps_ns, rho, rx)
    ok = eph.valid
    np.testing.assert_allclose(from_rho.range_m[ok], light.range_m[ok], atol=1e-3)
    np.testing.assert_allclose(from_rho.emission_offset_s[ok], -light.transit_s[ok], atol=1e-11)
    assert np.all((light.transit_s[ok] > 0.064) & (light.transit_s[ok] < 0.090))
    # Sagnac: the emission-time position turned by omega_e * tau about z moves 2 |r_xy| sin(omega_e tau / 2)
    unrotated = satellite_position_ecef(eph, obs.gps_ns, -light.transit_s)
    shift = np.linalg.norm(light.satellite_m - unrotated, axis=-1)[ok]
    radius_xy = np.hypot(unrotated[..., 0], unrotated[..., 1])[ok]
    expected = 2 * radius_xy * np.sin(OMEGA_EARTH_RAD_PER_S * light.transit_s[ok] / 2)
    np.testing.assert_allclose(shift, expected, rtol=1e-9)
    assert shift.max() > 100.0
