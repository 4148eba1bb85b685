"""Fixtures of the integrity tests: the two real Trimble 5700 stations (RTKLIB's sample data)."""

from __future__ import annotations

import pytest

from chronofuse.io.rinex import channel_clock_biases, read_gps_observations

from _helpers import TRIMBLE_STATIONS


@pytest.fixture(scope="session")
def trimble(real_data):
    """{station: (observations, C1 channel clock biases)} of both stations, read once per session."""
    base = real_data / "receivers" / "rinex" / "rtklib"
    out = {}
    for st in TRIMBLE_STATIONS:
        obs = read_gps_observations(base / f"{st}.05o")
        out[st] = (obs, channel_clock_biases(base / f"{st}.05o", base / f"{st}.05n", obs.approx_position_m))
    return out
