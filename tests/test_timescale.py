"""The time scales against published instants: IERS Bulletin C leap seconds, GPS week rollovers."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse import timescale as ts


def test_gps_minus_utc_is_18_seconds_since_2017_and_17_just_before():
    after = ts.utc_to_gps_ns(np.datetime64("2017-01-01T00:00:00"))
    before = ts.utc_to_gps_ns(np.datetime64("2016-12-31T23:59:59"))
    assert ts.gps_minus_utc_s(after) == 18
    assert ts.gps_minus_utc_s(before) == 17
    # The leap second 2016-12-31T23:59:60 sits between them: two GPS seconds for one UTC label step.
    assert after - before == 2 * ts.NS_PER_S


def test_gps_time_equalled_utc_at_the_gps_epoch():
    assert ts.utc_to_gps_ns(np.datetime64("1980-01-06T00:00:00")) == 0
    assert ts.gps_minus_utc_s(0) == 0
    assert ts.tai_minus_utc_s(np.datetime64("1980-01-06")) == ts.TAI_MINUS_GPS_S


def test_utc_round_trips_through_gps_ns_to_the_nanosecond():
    utc = np.array(["2015-06-30T23:59:59.123456789", "2015-07-01T00:00:00", "2025-01-01T00:00:00"],
                   dtype="datetime64[ns]")
    assert np.array_equal(ts.gps_ns_to_utc(ts.utc_to_gps_ns(utc)), utc)


def test_the_default_receiver_start_is_2025_new_year_utc():
    # 2025-01-01T00:00:00 UTC = GPS 1_419_724_818 s (GPS - UTC = 18 s).
    assert ts.utc_to_gps_ns(np.datetime64("2025-01-01T00:00:00")) == 1_419_724_818 * ts.NS_PER_S


def test_week_and_tow_of_the_2019_rollover():
    # 2019-04-07T00:00:00 GPS is the start of week 2048 (the second 1024-week rollover).
    gps_ns = ts.datetime64_to_gps_ns(np.datetime64("2019-04-07T00:00:00"))
    week, tow = ts.week_tow(gps_ns)
    assert (week, tow) == (2048, 0)
    assert ts.gps_ns_from_week_tow(week, tow) == gps_ns


def test_a_receiver_reporting_1024_weeks_early_is_moved_to_the_reference_era():
    reference = ts.datetime64_to_gps_ns(np.datetime64("2019-04-10"))
    assert ts.resolve_week(2048 - 1024, reference) == 2048
    assert ts.resolve_week(2047 % 1024, reference) == 2047
    assert ts.resolve_week(1023, ts.datetime64_to_gps_ns(np.datetime64("1999-08-20"))) == 1023


def test_instants_before_integer_utc_are_refused():
    with pytest.raises(ValueError, match="1972"):
        ts.tai_minus_utc_s(np.datetime64("1971-12-31"))


def test_seconds_to_ns_rounds_to_the_nearest_nanosecond():
    assert ts.seconds_to_ns(1e-9 * 0.6) == 1
    assert ts.seconds_to_ns(1799.9999999999998) == 1_800_000_000_000
