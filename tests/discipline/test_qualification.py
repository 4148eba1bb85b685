"""Source qualification: fix, time, satellites and GDOP < 5 (the GNSSDO paper section 3.2 (1))."""

import numpy as np
import pytest

from chronofuse.discipline.qualification import Qualification, usable_epochs
from chronofuse.models.receiver import simulate_receivers


def test_a_1pps_is_usable_only_with_fix_time_and_gdop_strictly_below_the_threshold():
    q = Qualification()
    fix = np.array([True, True, True, False, True, True])
    time_valid = np.array([True, True, False, True, True, True])
    gdop = np.array([4.99, 5.0, 2.0, 2.0, np.nan, 1.0])
    n_sats = np.array([6, 6, 6, 6, 6, 3])
    assert q.usable(fix, time_valid, gdop, n_sats).tolist() == [True, False, False, False, False, False]


def test_the_gdop_threshold_is_configurable():
    fix = np.ones(3, bool)
    gdop = np.array([1.5, 3.0, 7.0])
    assert Qualification(gdop_max=2.0).usable(fix, fix, gdop, 8).tolist() == [True, False, False]
    assert Qualification(gdop_max=10.0).usable(fix, fix, gdop, 8).tolist() == [True, True, True]


@pytest.mark.parametrize("value", [0.5, 0.0, -1.0, float("nan")])
def test_a_gdop_threshold_below_one_is_refused_naming_the_parameter(value):
    with pytest.raises(ValueError, match="gdop_max"):
        Qualification(gdop_max=value)


def test_urban_canyon_receivers_lose_about_the_epochs_whose_gdop_is_five_or_more():
    rx = simulate_receivers("urban-canyon", 3000, 2, seed=3)
    ep = rx.epochs
    usable = usable_epochs(ep, pps_present=np.isfinite(rx.pps_error_s))
    with np.errstate(invalid="ignore"):
        expected = ep.has_fix & ep.time_valid & (ep.gdop < 5) & (ep.n_sats >= 4)
    assert np.array_equal(usable, expected)
    # The scenario is built so that GDOP > 5 is frequent: qualification must reject a real share.
    assert 0.05 < 1 - usable[ep.has_fix].mean() < 0.6


def test_open_sky_receivers_are_usable_whenever_they_have_a_fix():
    rx = simulate_receivers("open-sky", 2000, 1, seed=4)
    assert np.array_equal(usable_epochs(rx.epochs), rx.epochs.has_fix)
