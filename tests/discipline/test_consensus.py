"""UTC and leap-second consensus: dissenters flagged, a pending leap inserted at 23:59:60."""

import numpy as np

from chronofuse.discipline.consensus import apply_leap, utc_consensus
from chronofuse.models.receiver import GPS_MINUS_UTC_S, simulate_receivers
from chronofuse.timescale import NS_PER_S, utc_to_gps_ns


class _Run:
    """One receiver's time reports around a leap second, as (steps,) arrays."""

    def __init__(self, ep):
        self.gps_s = ep.gps_ns // NS_PER_S
        self.utc_s = ep.utc_ns()[0, 0] // NS_PER_S
        self.leap_s = ep.leap_s[0, 0].astype(np.int64)
        self.leap_pending = ep.leap_pending[0, 0].astype(np.int64)


def _gps_s(utc: str) -> int:
    """GPS seconds of a UTC instant of 2025 or later (GPS - UTC = 18 s until a leap)."""
    return int(utc_to_gps_ns(np.datetime64(utc)) // NS_PER_S)


#: The end of a month a leap second may close (ITU-R TF.460-6 prefers June and December).
MIDNIGHT = "2025-07-01T00:00:00"


def _receivers_around_a_leap():
    start = _gps_s("2025-06-30T23:55:00")
    event = _gps_s(MIDNIGHT) + 1  # first GPS second with GPS - UTC = 19 s
    rx = simulate_receivers("open-sky", 600, 1, seed=0, start_gps_s=start, leap_event_gps_s=event, leap_announce_s=3600)
    return _Run(rx.epochs), start, event


def test_a_receiver_with_the_wrong_utc_second_is_flagged_and_outvoted():
    rx, _, _ = _receivers_around_a_leap()
    utc = np.tile(rx.utc_s, (3, 1))
    utc[2, 100:200] += 1  # one receiver labels its seconds one late
    leap = np.tile(rx.leap_s, (3, 1))
    pend = np.tile(rx.leap_pending, (3, 1))
    c = utc_consensus(utc, leap, pend, np.ones(utc.shape, bool))
    assert np.array_equal(c.utc_s, rx.utc_s) and c.quorum.all()
    assert c.dissent[2, 100:200].all() and not c.dissent[:2].any() and not c.dissent[2, :100].any()


def test_a_receiver_with_a_stale_leap_count_is_flagged():
    rx, _, _ = _receivers_around_a_leap()
    leap = np.tile(rx.leap_s, (3, 1))
    leap[0] = GPS_MINUS_UTC_S  # never learns of the leap
    c = utc_consensus(np.tile(rx.utc_s, (3, 1)), leap, np.tile(rx.leap_pending, (3, 1)), np.ones((3, 600), bool))
    assert np.array_equal(c.leap_s, rx.leap_s)
    assert c.dissent[0].sum() == np.sum(rx.leap_s != GPS_MINUS_UTC_S)


def test_two_receivers_that_disagree_have_no_quorum():
    c = utc_consensus(np.array([[10], [11]]), np.array([[18], [18]]), np.zeros((2, 1), bool), np.ones((2, 1), bool))
    assert not c.quorum[0]


def test_the_pending_leap_second_is_inserted_after_235959_utc():
    rx, start, event = _receivers_around_a_leap()
    sched = apply_leap(rx.gps_s, GPS_MINUS_UTC_S, rx.leap_pending)
    assert np.array_equal(sched.leap_s, rx.leap_s)  # the receiver model's truth
    k = int(np.flatnonzero(sched.leap_second)[0])
    assert rx.gps_s[k] == event - 1 and sched.leap_second.sum() == 1
    # 23:59:60 repeats the label of the next midnight (UTC seconds counted from the GPS epoch, as the receivers do):
    midnight = (np.datetime64(MIDNIGHT, "s") - np.datetime64("1980-01-06T00:00:00", "s")).astype(np.int64)
    assert sched.utc_s[k] == midnight
    assert sched.utc_s[k] == sched.utc_s[k + 1] and sched.utc_s[k] % 86_400 == 0


def test_the_leap_is_applied_on_time_even_when_receivers_update_their_count_late():
    rx, _, event = _receivers_around_a_leap()
    late = np.where(rx.gps_s >= event + 10, rx.leap_s, GPS_MINUS_UTC_S)
    c = utc_consensus(np.tile(rx.gps_s - late, (3, 1)), np.tile(late, (3, 1)), np.tile(rx.leap_pending, (3, 1)),
                      np.ones((3, 600), bool))
    sched = apply_leap(rx.gps_s, GPS_MINUS_UTC_S, c.leap_pending)
    assert np.array_equal(sched.leap_s, rx.leap_s)


def test_a_pending_negative_leap_skips_235959():
    start = _gps_s(MIDNIGHT) - 10
    gps = np.arange(start, start + 20)
    pending = np.full(20, -1)
    sched = apply_leap(gps, GPS_MINUS_UTC_S, pending)
    labels = sched.utc_s % 86_400
    assert 86_399 not in labels.tolist()
    k = int(np.flatnonzero(labels == 0)[0])
    assert sched.leap_s[k] == GPS_MINUS_UTC_S - 1 and sched.leap_s[k - 1] == GPS_MINUS_UTC_S
    assert np.count_nonzero(np.diff(sched.utc_s) == 2) == 1  # 23:59:58 -> 00:00:00
