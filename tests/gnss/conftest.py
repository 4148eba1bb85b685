"""The two RTKLIB Trimble 5700 stations (RINEX 2.10, 120 epochs at 30 s, 2005-04-02), read once per session."""

from __future__ import annotations

import pytest

from chronofuse.io.rinex import read_gps_navigation, read_gps_observations

STATIONS = ("07590920", "30400920")


@pytest.fixture(scope="session")
def rtklib_dir(data_dir):
    return data_dir / "receivers" / "rinex" / "rtklib"


@pytest.fixture(scope="session")
def rtklib(rtklib_dir):
    """``{station: (GpsObservations, GpsNavigation)}``."""
    return {st: (read_gps_observations(rtklib_dir / f"{st}.05o"), read_gps_navigation(rtklib_dir / f"{st}.05n"))
            for st in STATIONS}
