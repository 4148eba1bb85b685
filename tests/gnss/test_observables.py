"""Observables: pseudoranges -> per-satellite receiver clock biases, against a second geometry and the SPP clock."""

from __future__ import annotations

import math

import numpy as np
import pytest

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.atmosphere import klobuchar_delay_s, saastamoinen_delay_m
from chronofuse.gnss.ephemeris import geometry_from_light_time, select_ephemeris
from chronofuse.gnss.geodesy import elevation_azimuth
from chronofuse.gnss.observables import channel_biases, channel_clock_biases_from_arrays
from chronofuse.gnss.spp import single_point_position
from chronofuse.io.rinex import channel_clock_biases
from chronofuse.timescale import NS_PER_S, week_tow


def _synthetic_pseudoranges(obs, nav, clock_bias_s):
    """Pseudoranges a receiver at the header position with clock bias ``clock_bias_s`` would measure at the
    true receive times ``obs.gps_ns``: ``rho = |r_sat(t - tau) - r_rx| + c (b - dt_sat) + I + T``, with the
    geometry from the light-time iteration (not from the pseudorange, as :func:`channel_biases` solves it)."""
    rx = obs.approx_position_m
    light = geometry_from_light_time(select_ephemeris(nav, obs.satellites, obs.gps_ns), obs.gps_ns, rx)
    el, az = elevation_azimuth(rx, light.satellite_m)
    tow_s = week_tow(obs.gps_ns)[1][:, None] / NS_PER_S
    iono_s = klobuchar_delay_s(nav.klobuchar_alpha, nav.klobuchar_beta, rx, el, az, tow_s)
    tropo_m = saastamoinen_delay_m(rx, el)
    c = SPEED_OF_LIGHT_M_PER_S
    return light.range_m + c * (clock_bias_s - light.clock_s + iono_s) + tropo_m


def test_channel_biases_give_back_the_clock_bias_of_light_time_pseudoranges(rtklib):
    obs, nav = rtklib["30400920"]
    clock_bias_s = 2.5e-4 + 1e-9 * np.arange(obs.gps_ns.size)[:, None]
    rho = _synthetic_pseudoranges(obs, nav, clock_bias_s)
    tags = obs.gps_ns + np.rint(clock_bias_s[:, 0] * NS_PER_S).astype(np.int64)  # the receiver's own time tags
    bias_s, el = channel_biases(nav, obs.satellites, tags, rho, obs.approx_position_m, elevation_mask_deg=5.0)
    seen = np.isfinite(bias_s)
    assert seen.sum() > 1000
    # the emission time solved from the pseudorange equals the light-time one whatever the receiver clock,
    # so every channel returns the clock bias (measured: within 2.3e-13 s above 5 deg). Not near the horizon: there the pseudorange
    # holds km of troposphere, the solved emission time is early by T/c and, with the steep mapping function,
    # the elevation error of that shift costs ~7 mm at 0.05 deg (measured)
    np.testing.assert_allclose(bias_s[seen], np.broadcast_to(clock_bias_s, bias_s.shape)[seen], rtol=0, atol=1e-12)
    assert np.all(el[seen] >= np.radians(5.0))


def test_channels_below_the_elevation_mask_are_nan(rtklib):
    obs, nav = rtklib["07590920"]
    bias_s, el = channel_biases(nav, obs.satellites, obs.gps_ns, obs.pseudorange_m, obs.approx_position_m,
                                elevation_mask_deg=15.0)
    observed = np.isfinite(obs.pseudorange_m)
    low = observed & (el < math.radians(15.0))
    assert low.sum() > 0
    assert np.isnan(bias_s[low]).all()
    assert np.isfinite(bias_s[observed & ~low]).all()


def test_channel_biases_agree_with_the_single_point_clock(rtklib, rtklib_dir):
    obs, nav = rtklib["30400920"]
    _, clock_s, _ = single_point_position(obs, nav, elevation_mask_deg=10.0)
    biases = channel_clock_biases(rtklib_dir / "30400920.05o", rtklib_dir / "30400920.05n", obs.approx_position_m,
                                  elevation_mask_deg=10.0, epoch_time="tag")
    # two methods for the receiver clock: the median channel bias at the known position and the
    # least-squares solution with the position free (its height error, about 1-3 m, trades against its
    # clock); measured: median 2.0 ns, at most 11 ns apart
    diff = np.nanmedian(biases.bias_s, axis=1) - clock_s
    assert np.nanmax(np.abs(diff)) < 15e-9


def test_from_arrays_checks_shapes():
    with pytest.raises(ValueError, match="dimension"):
        channel_clock_biases_from_arrays(np.zeros(10), 1.0)
    with pytest.raises(ValueError, match="names"):
        channel_clock_biases_from_arrays(np.zeros((10, 3)), 1.0, ["G01"])
