"""The simulated error budget against the real stations' GPS-only statistics (open sky, same day and place)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from chronofuse.experiments.error_budget import horizontal95_ci_block_bootstrap, station_budget_check
from chronofuse.gnss.simulate import ENVIRONMENTS


def _overlap(a, b) -> bool:
    return a[0] <= b[1] and b[0] <= a[1]


@pytest.mark.parametrize("name", ["ESBC", "BOR1"])
def test_simulated_open_sky_gps_errors_match_the_mid_latitude_stations_within_their_intervals(igs_stations, name):
    check = station_budget_check(igs_stations[name], trials=8, seed=21)
    assert _overlap(check["simulated_ci_m"], check["real_ci_m"]), check
    assert 0.7 < check["simulated_horizontal95_m"] / check["real_horizontal95_m"] < 1.4


def test_the_budget_is_conservative_in_the_arctic_and_says_so(igs_stations):
    # NYA1 (78.9 N): the polar ionosphere is quieter than the mid-latitude residual the budget carries
    check = station_budget_check(igs_stations["NYA1"], trials=8, seed=21)
    assert check["simulated_ci_m"][0] > check["real_ci_m"][1]
    assert check["simulated_horizontal95_m"] < 1.6 * check["real_horizontal95_m"]


def test_a_budget_without_residual_atmosphere_does_not_match_the_real_stations(igs_stations):
    # negative verdict: the match is the atmosphere's doing, not a free outcome of any budget
    quiet = dataclasses.replace(ENVIRONMENTS["open-sky"], iono_zenith_m=0.0, tropo_zenith_m=0.0)
    from chronofuse.experiments.error_budget import simulated_station

    s = igs_stations["BOR1"]
    real = station_budget_check(s, trials=4, seed=3)
    sim = np.nanpercentile(simulated_station(s, 4, env=quiet, seed=3, step=2), 95, axis=1)
    assert sim.max() < 0.75 * real["real_ci_m"][0]


def test_the_block_bootstrap_interval_covers_a_known_percentile_and_widens_with_correlation():
    rng = np.random.default_rng(5)
    white = np.abs(rng.standard_normal(20_000))
    value, low, high = horizontal95_ci_block_bootstrap(white, block=1, resamples=500)
    assert low < 1.95996 < high and abs(value - 1.96) < 0.05
    correlated = np.abs(np.repeat(rng.standard_normal(200), 100))  # 100-epoch blocks of one value
    _, lo1, hi1 = horizontal95_ci_block_bootstrap(correlated, block=1, resamples=500)
    _, lo2, hi2 = horizontal95_ci_block_bootstrap(correlated, block=100, resamples=500)
    assert hi2 - lo2 > 3 * (hi1 - lo1)
