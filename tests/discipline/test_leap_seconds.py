"""Leap seconds right: one insertion (or deletion) at the end of the announced month, whatever the flag's
timing; the count checked against the IERS table; the consensus labels the GNSSDO's output.

The leaps here are hypothetical ones at the ends of 2027 months, past the built-in table's horizon (within
it the table decides; a test below shows that too)."""

import numpy as np
import pytest

from chronofuse.discipline.consensus import apply_leap, table_leap_s, utc_consensus
from chronofuse.discipline.utc_stage import LeapStage
from chronofuse.timescale import NS_PER_S, utc_to_gps_ns


def _gps_s(utc: str) -> int:
    return int(utc_to_gps_ns(np.datetime64(utc)) // NS_PER_S)


def _frame(start_utc: str, steps: int, receivers: int, leap, pending):
    """Receivers' time reports on one grid: ``leap`` and ``pending`` (steps,) or (receivers, steps)."""
    gps = _gps_s(start_utc) + np.arange(steps)
    shape = (1, receivers, steps)
    return {"t_ns": np.broadcast_to(gps * NS_PER_S, shape).copy(),
            "leap_s": np.broadcast_to(np.asarray(leap, dtype=np.int64), shape).copy(),
            "leap_pending": np.broadcast_to(np.asarray(pending, dtype=np.int64), shape).copy(),
            "time_valid": np.ones(shape, bool)}, gps


def test_a_pending_flag_that_lingers_after_the_event_inserts_one_leap_second():
    # Receivers announce from 23:00, switch their count at the event, and keep the flag up 3 s more.
    steps = 7200
    frame, gps = _frame("2027-06-30T23:00:00", steps, 3, 18, 1)
    event = _gps_s("2027-07-01T00:00:00") + 1  # the first second counted with 19 (GPS seconds, 18 s ahead of UTC)
    frame["leap_s"][..., gps >= event] = 19
    frame["leap_pending"][..., gps >= event + 3] = 0
    out = LeapStage().run(frame)
    assert out["leap_second"].sum() == 1
    assert set(out["utc_leap_s"][0].tolist()) == {18, 19}
    k = int(np.flatnonzero(out["leap_second"][0])[0])
    assert gps[k] == event - 1 and (out["utc_leap_s"][0, k + 1:] == 19).all()
    # The output's label never jumps nor runs backwards, save the one repeated label of 23:59:60.
    assert np.count_nonzero(np.diff(out["utc_label_s"][0]) == 0) == 1 and (np.diff(out["utc_label_s"][0]) <= 1).all()


def test_an_announcement_30_days_early_is_applied_at_the_month_end_not_the_next_midnight():
    # The flag up from 2025-06-01: nothing at the end of June 1 (the old rule inserted a leap there) ...
    day = 86_400
    frame, gps = _frame("2027-06-01T00:00:00", day + 600, 3, 18, 1)
    out = LeapStage().run(frame)
    assert not out["leap_second"].any() and (out["utc_leap_s"] == 18).all()
    # ... and exactly one at the end of June 30, with the flag still up 30 days on.
    sched = apply_leap(_gps_s("2027-06-30T23:50:00") + np.arange(1200), 18, np.ones(1200, int))
    assert sched.leap_second.sum() == 1
    k = int(np.flatnonzero(sched.leap_second)[0])
    midnight = int((np.datetime64("2027-07-01T00:00:00", "s") - np.datetime64("1980-01-06", "s")).astype(np.int64))
    assert sched.utc_s[k] == midnight and sched.leap_s[k + 1] == 19


def test_a_negative_leap_second_skips_235959_once_at_the_month_end():
    gps = _gps_s("2027-12-31T23:50:00") + np.arange(1200)
    sched = apply_leap(gps, 18, -np.ones(1200, int))
    labels = sched.utc_s % 86_400
    assert 86_399 not in labels.tolist() and np.count_nonzero(np.diff(sched.utc_s) == 2) == 1
    assert set(sched.leap_s.tolist()) == {18, 17} and not sched.leap_second.any()


def test_one_dissenting_receiver_is_flagged_and_the_majority_decides():
    steps = 1200
    pending = np.ones((3, steps), int)
    pending[2] = 0  # one receiver never hears of the leap
    frame, gps = _frame("2027-06-30T23:50:00", steps, 3, 18, pending)
    out = LeapStage().run(frame)
    assert out["leap_second"].sum() == 1
    assert out["leap_dissent"][0, 2].all() and not out["leap_dissent"][0, :2].any()
    # The other way round: one receiver alone announces a leap that is not coming.
    pending = np.zeros((3, steps), int)
    pending[0] = 1
    frame, _ = _frame("2027-06-30T23:50:00", steps, 3, 18, pending)
    out = LeapStage().run(frame)
    assert not out["leap_second"].any() and out["leap_dissent"][0, 0].all()


def test_a_lone_receiver_with_a_wrong_count_is_caught_by_the_table():
    steps = 100
    frame, gps = _frame("2026-03-01T00:00:00", steps, 1, 17, 0)  # GPS - UTC is 18 s in 2026
    c = utc_consensus(gps[None, :] - 17, frame["leap_s"][0], frame["leap_pending"][0], frame["time_valid"][0],
                      gps * NS_PER_S)
    assert c.table_mismatch.all() and c.dissent.all()
    assert (c.leap_s == 18).all() and (c.utc_s == gps - 18).all()
    out = LeapStage().run(frame)
    assert (out["utc_leap_s"] == 18).all() and out["leap_dissent"].all()
    # Past the table's horizon the same receiver, alone, has nothing to be checked against.
    table, known = table_leap_s(np.array([_gps_s("2027-01-01T00:00:00") * NS_PER_S]))
    assert not known[0] and table[0] == 18


def test_within_the_tables_horizon_an_announced_leap_the_table_lacks_is_not_applied():
    steps = 1200
    frame, gps = _frame("2025-06-30T23:50:00", steps, 3, 18, 1)  # no leap second ended June 2025
    out = LeapStage().run(frame)
    assert not out["leap_second"].any() and (out["utc_leap_s"] == 18).all()


def test_the_stage_streams_second_by_second_as_it_runs():
    steps = 1200
    pending = np.ones((3, steps), int)
    pending[1, :300] = 0
    frame, gps = _frame("2027-06-30T23:50:00", steps, 3, 18, pending)
    batch = LeapStage().run(frame)
    stage = LeapStage()
    for k in range(steps):
        step = stage.step({name: value[..., k] for name, value in frame.items()})
        for name in batch:
            assert np.array_equal(np.asarray(step[name]), batch[name][..., k]), (name, k)


@pytest.mark.parametrize("leap_at", ["2027-06-30", "2027-12-31"])
def test_the_gnssdo_output_is_labelled_by_the_consensus(leap_at):
    from chronofuse.discipline.chain import ChainConfig, discipline_run
    from chronofuse.discipline.dac import Dac
    from chronofuse.experiments.gnssdo import _free_phase, make_controller, scenario_environment
    from chronofuse.models.oscillator_presets import preset
    from chronofuse.models.receiver import simulate_receivers
    from chronofuse.seeding import root_seed

    osc = preset("ocxo")
    env = scenario_environment("open-sky", 3600)
    midnight = _gps_s(f"{leap_at}T00:00:00") + 86_400  # the next midnight, in GPS seconds
    start = midnight - 1800
    rx = simulate_receivers(env, 3600, 3, 4, start_gps_s=start, leap_event_gps_s=midnight + 1,
                            leap_announce_s=2 * 86_400)
    free, _ = _free_phase(osc, 3600, 1, root_seed(1))
    run = discipline_run(make_controller("gated-kalman", osc, env, 3, Dac.for_oscillator(osc)), free, rx.pps_error_s,
                         rx.epochs, ChainConfig())
    assert run.leap["leap_second"].sum() == 1
    assert np.array_equal(run.leap["utc_label_s"][0], rx.epochs.utc_ns()[0, 0] // NS_PER_S)
