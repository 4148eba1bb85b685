"""ReceiverEpochs: the per-epoch receiver record (layout, validation, UTC labels, selection, export)."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
import pytest

from chronofuse.epochs import EXPORT_COLUMNS, ReceiverEpochs
from chronofuse.models.receiver import simulate_receivers
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_minus_utc_s, gps_ns_to_utc, utc_to_gps_ns

GPS_EPOCH = dt.datetime(1980, 1, 6)


def make(gps_ns, trials=1, receivers=1, leap_s=18, **fields) -> ReceiverEpochs:
    return ReceiverEpochs(**{**ReceiverEpochs.absent(gps_ns, trials, receivers, leap_s=leap_s), **fields})


def grid(start_utc: str, n: int, step_s: int = 1) -> np.ndarray:
    return utc_to_gps_ns(np.datetime64(start_utc, "ns")) + np.arange(n, dtype=np.int64) * step_s * NS_PER_S


def test_a_source_that_reports_nothing_has_mode_zero_and_nan_measurements():
    ep = make(grid("2025-01-01T00:00:00", 5), trials=2, receivers=3)
    assert ep.shape == (2, 3, 5)
    assert (ep.fix_mode == 0).all() and not ep.time_valid.any() and not ep.has_fix.any()
    assert (ep.n_sats == -1).all() and (ep.leap_pending == 0).all() and (ep.leap_s == 18).all()
    for name in ("gdop", "pdop", "hdop", "vdop", "tdop", "qerr_s", "clock_bias_s", "clock_drift_s_per_s"):
        assert np.isnan(getattr(ep, name)).all(), name


def test_arrays_are_read_only_and_stored_with_their_documented_dtypes():
    ep = make(grid("2025-01-01T00:00:00", 4), fix_mode=np.full((1, 1, 4), 3), n_sats=np.full((1, 1, 4), 9))
    assert ep.fix_mode.dtype == np.int8 and ep.n_sats.dtype == np.int16 and ep.gps_ns.dtype == np.int64
    with pytest.raises(ValueError):
        ep.fix_mode[0, 0, 0] = 1
    with pytest.raises(ValueError):
        ep.gps_ns[0] = 0


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"gdop": np.zeros((1, 1, 3))}, "gdop"),  # wrong number of epochs
        ({"gdop": np.zeros((1, 4))}, "gdop"),  # layout is (trials, receivers, epochs)
        ({"time_valid": np.zeros((1, 1, 4))}, "time_valid"),  # float where bool is due
        ({"n_sats": np.zeros((1, 1, 4))}, "n_sats"),  # float where int is due
        ({"fix_mode": np.full((1, 1, 4), 4)}, "fix_mode"),  # gpsd modes are 0..3
        ({"leap_pending": np.full((1, 1, 4), 2)}, "leap_pending"),
        ({"n_sats": np.full((1, 1, 4), -2)}, "n_sats"),
        ({"n_sats": np.full((1, 1, 4), 40_000)}, "n_sats"),  # does not fit int16
        ({"gps_ns": np.array([3, 2, 1, 0], dtype=np.int64)}, "gps_ns"),  # not increasing
        ({"gps_ns": np.arange(4.0)}, "gps_ns"),  # a float epoch
    ],
)
def test_a_malformed_field_is_refused_naming_it(change, field):
    base = ReceiverEpochs.absent(np.arange(4, dtype=np.int64) * NS_PER_S, 1, 1, leap_s=18)
    with pytest.raises(ValueError, match=field):
        ReceiverEpochs(**{**base, **change})


def test_utc_label_is_the_calendar_gps_minus_the_announced_leap():
    # Independent check with the standard library: GPS seconds since 1980-01-06 minus 18 leap seconds.
    gps_ns = grid("2025-03-01T12:00:00", 3, step_s=7)
    ep = make(gps_ns)
    for k in range(3):
        calendar = GPS_EPOCH + dt.timedelta(seconds=int(gps_ns[k] // NS_PER_S) - 18)
        assert calendar == dt.datetime(2025, 3, 1, 12, 0, 7 * k)
        assert ep.to_frame().time_utc[k] == calendar.strftime("%Y-%m-%dT%H:%M:%S.000Z")


def test_utc_follows_the_receivers_leap_across_the_2016_leap_second_like_the_table():
    # 2016-12-31T23:59:59 UTC to 2017-01-01T00:00:01 UTC: GPS - UTC goes 17 -> 18 s; four GPS seconds.
    gps_ns = utc_to_gps_ns(np.datetime64("2016-12-31T23:59:59", "ns")) + np.arange(4, dtype=np.int64) * NS_PER_S
    leap = gps_minus_utc_s(gps_ns).reshape(1, 1, 4)  # what a receiver with a current almanac announces
    ep = make(gps_ns, leap_s=leap)
    np.testing.assert_array_equal(ep.utc_ns()[0, 0], datetime64_to_gps_ns(gps_ns_to_utc(gps_ns)))
    # 23:59:60 has no POSIX label: it repeats the following midnight.
    assert list(ep.to_frame().time_utc) == ["2016-12-31T23:59:59.000Z", "2017-01-01T00:00:00.000Z",
                                            "2017-01-01T00:00:00.000Z", "2017-01-01T00:00:01.000Z"]


def test_a_wrong_leap_count_shows_in_the_utc_label():
    # A receiver that has not read the almanac yet and still assumes GPS - UTC = 0 s is 18 s late in UTC.
    gps_ns = grid("2025-01-01T00:00:00", 2)
    assert make(gps_ns, leap_s=0).to_frame().time_utc[0] == "2025-01-01T00:00:18.000Z"


def test_select_keeps_the_layout_and_picks_the_receiver_and_trial():
    truth = simulate_receivers("urban-canyon", 300, 3, seed=4, trials=2)
    one = truth.epochs.select(receiver=2, trial=1)
    assert one.shape == (1, 1, 300)
    np.testing.assert_array_equal(one.clock_bias_s[0, 0], truth.epochs.clock_bias_s[1, 2])
    np.testing.assert_array_equal(one.gps_ns, truth.epochs.gps_ns)
    with pytest.raises(ValueError, match="receiver"):
        truth.epochs.select(receiver=3)


def test_export_has_the_documented_columns_one_row_per_epoch():
    truth = simulate_receivers("jamming", 700, 2, seed=3)
    frame = truth.epochs.to_frame(receiver=1)
    assert tuple(frame.columns) == EXPORT_COLUMNS
    assert len(frame) == 700
    ep = truth.epochs
    np.testing.assert_array_equal(frame.clock_bias_s, ep.clock_bias_s[0, 1])
    np.testing.assert_array_equal(frame.qerr_s, ep.qerr_s[0, 1])
    np.testing.assert_array_equal(frame["mode"], np.where(ep.time_valid[0, 1], 3, 1))
    assert (frame["mode"][600:700] == 1).all()  # jammed from 600 s: no fix
    assert frame.clock_drift.isna().all() and frame.pdop.isna().all()  # not modelled: absent
    # time_utc is ISO 8601 UTC that parses back to the epoch's UTC label, to the nanosecond.
    parsed = pd.to_datetime(frame.time_utc).dt.tz_convert(None).to_numpy().astype("datetime64[ns]")
    np.testing.assert_array_equal(datetime64_to_gps_ns(parsed), ep.utc_ns()[0, 1])
