"""Verdicts that mean what they say: a stale receiver, a dissenting one, one with a latched alarm and one
with a wrong leap count alone are never reported usable, each with its reason; the same receivers without
the fault are (the positive controls); every unusable epoch names why."""

from __future__ import annotations

import threading
import time

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from _real_parts import TcpReceiver
from chronofuse.io.arrival import REORDER_EPOCHS
from chronofuse.discipline.verdict import (LEAP_TABLE_KNOWN_UNTIL_GPS_NS, ReceiverVerdict, reasons, verdict_bits)
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.io.replay import ReplaySource, SharedStart
from chronofuse.io.sources import TcpSource
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.status import status_document
from chronofuse.timescale import NS_PER_S, gps_minus_utc_s

from .conftest import WEEK, ubx_epochs, ubx_stream

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=3.0)
KNOWN = MonitorSettings(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)


def _bias(steps, seed, anomaly=None):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=seed).measured_s[0]
    return inject(x, anomaly, 1.0) if anomaly is not None else x


def _replay(tmp_path, streams: dict[str, bytes], settings=KNOWN) -> tuple[Monitor, list[dict]]:
    """The streams replayed together at 50x (each epoch's bursts sent at one instant, as GPS-locked
    receivers send them), every epoch decided with all the receivers."""
    sources, start = [], SharedStart(lead_s=0.5)
    for name, data in streams.items():
        path = tmp_path / f"{name}.ubx"
        path.write_bytes(data)
        sources.append(ReplaySource(path, name=name, speed=50.0, start_at=start))
    acked: list[dict] = []
    mon = Monitor(sources, settings, on_ack=acked.extend, hold_s=60.0)  # each epoch decided with all receivers
    mon.run(duration_s=60)
    return mon, acked


def test_a_receiver_reporting_leap_17_with_a_clock_step_is_never_usable_while_the_others_are(tmp_path):
    # the operator's case: leap 17 s and a 1 us clock step; two honest receivers beside it
    streams = {"honest1": ubx_stream(_bias(120, 1)), "honest2": ubx_stream(_bias(120, 2)),
               "wrong": ubx_stream(_bias(120, 3, Anomaly("step", 60.0, offset_s=1e-6)), leap_s=17)}
    _, acked = _replay(tmp_path, streams)
    wrong = [r for r in acked if r["receiver"] == "wrong"]
    assert len(wrong) == 120
    assert all(r["dissent"] for r in wrong), [(r["utc"], r["leap_s"], r["time_valid"]) for r in wrong if not r["dissent"]]
    assert not any(r["usable"] for r in wrong)  # was usable in 449 of 449 epochs before
    assert all(any("dissent" in why for why in r["reasons"]) for r in wrong)
    assert all(any("leap-second table" in why for why in r["reasons"]) for r in wrong)
    honest = [r for r in acked if r["receiver"] != "wrong"]
    tested = [r for r in honest if r["state"] in ("ok", "alarm")]
    assert len(tested) > 180 and all(r["usable"] and not r["reasons"] for r in tested)  # the positive control
    # before the detector's window is full the integrity test has not tested an epoch: not usable, and says so
    assert all(not r["usable"] and r["reasons"] == ["integrity not tested (no test statistic)"]
               for r in honest if r not in tested)


def test_a_lone_receiver_with_a_wrong_leap_count_is_not_usable_and_the_table_says_why(tmp_path):
    _, acked = _replay(tmp_path, {"alone": ubx_stream(_bias(40, 4), leap_s=17)})
    assert acked and not any(r["usable"] for r in acked)
    assert not any(r["dissent"] for r in acked)  # nobody to dissent from: the table is the referee
    table = "leap 17 s disagrees with the leap-second table (18 s)"
    assert all(r["reasons"] == [table] for r in acked if r["state"] == "ok")
    assert all(r["reasons"] == [table, "integrity not tested (no test statistic)"] for r in acked if r["state"] != "ok")
    _, acked = _replay(tmp_path, {"alone": ubx_stream(_bias(40, 4), leap_s=18)})
    assert all(r["usable"] == (r["state"] == "ok") for r in acked) and any(r["usable"] for r in acked)


def test_a_receiver_whose_alarm_is_latched_is_not_usable_for_as_long_as_it_is_latched(tmp_path):
    # a ramp (a frequency step of 50 ns/s): the second difference sees its onset only, the latch holds
    bias = _bias(200, 5, Anomaly("ramp", 100.0, rate_s_per_s=50e-9))
    _, acked = _replay(tmp_path, {"rx": ubx_stream(bias)})
    latched = [r for r in acked if r["state"] == "alarm"]
    assert len(latched) > 20  # held after the onset's differences have left the window
    assert sum(r["alarm"] for r in acked) < len(latched)  # the epochs over threshold are fewer
    assert not any(r["usable"] for r in latched)
    assert all("integrity alarm (latched)" in r["reasons"] for r in latched)
    before = [r for r in acked if r["gps_ns"] < acked[0]["gps_ns"] + 95 * NS_PER_S and r["state"] == "ok"]
    assert before and all(r["usable"] for r in before)


def test_a_receiver_that_goes_silent_with_its_link_open_becomes_stale_and_unusable():
    rx = TcpReceiver()
    # 9 epochs for the grid to learn its interval, and the reorder buffer's (chronofuse.io.arrival) after them
    epochs = ubx_epochs(_bias(10 + REORDER_EPOCHS, 6), start_tow_s=300_000, eoe=True)
    mon = Monitor([TcpSource("127.0.0.1", rx.port, name="quiet")], KNOWN, stale_s=1.0)
    runner = threading.Thread(target=mon.run, kwargs={"duration_s": 6.0}, daemon=True)
    runner.start()
    try:
        for data in epochs:
            rx.send(data)
            time.sleep(0.2)
        deadline = time.monotonic() + 5
        while mon.acknowledged < len(epochs) and time.monotonic() < deadline:  # the held epochs come too
            time.sleep(0.05)
        assert mon.acknowledged == len(epochs)
        fresh = status_document(mon)["receivers"][0]
        assert fresh["usable"] is True and not fresh["stale"] and fresh["link"] == "up"
        time.sleep(2.0)  # the link stays up; nothing comes
        quiet = status_document(mon)["receivers"][0]
        assert quiet["link"] == "up" and quiet["stale"] and quiet["age_s"] > 1.0
        assert quiet["usable"] is False
        assert any(why.startswith("stale: no epoch for") for why in quiet["reasons"])
        assert quiet["last"]["utc"] == fresh["last"]["utc"]  # its old UTC is shown, with its age
        assert mon.is_stale("quiet")
    finally:
        runner.join(10)
        rx.close()


_EPOCH = st.fixed_dictionaries({
    "fix_mode": st.integers(0, 3), "time_valid": st.booleans(), "gdop": st.one_of(st.just(float("nan")),
                                                                                  st.floats(0.5, 20.0)),
    "n_sats": st.integers(-1, 20), "leap_s": st.integers(14, 20), "state": st.sampled_from(["ok", "alarm", "unavailable"]),
    "dissent": st.booleans(), "jump": st.booleans(),
    "t_ns": st.integers((WEEK - 600) * 604_800 * NS_PER_S, (WEEK + 200) * 604_800 * NS_PER_S)})


@settings(max_examples=300, deadline=None)
@given(_EPOCH)
def test_usable_exactly_when_every_condition_holds_and_an_unusable_epoch_names_each_failure(epoch):
    stage = ReceiverVerdict(gdop_max=5.0, min_sats=4)
    out = stage.step(epoch)
    table = int(gps_minus_utc_s(np.int64(epoch["t_ns"])))
    leap_ok = epoch["leap_s"] == table or (epoch["t_ns"] >= LEAP_TABLE_KNOWN_UNTIL_GPS_NS and epoch["leap_s"] == table + 1)
    expected = (epoch["fix_mode"] >= 2 and epoch["time_valid"] and epoch["gdop"] == epoch["gdop"]
                and epoch["gdop"] < 5.0 and epoch["n_sats"] >= 4 and epoch["state"] == "ok"
                and not epoch["dissent"] and not epoch["jump"] and leap_ok)
    assert out["usable"] == expected
    words = reasons(out["unusable_bits"], epoch, gdop_max=5.0, min_sats=4)
    assert bool(words) == (not expected)
    assert len(words) == bin(out["unusable_bits"]).count("1")
    # the batch path (arrays) gives the step's verdict
    frame = {k: np.array([v]) for k, v in epoch.items()}
    assert stage.run(frame)["unusable_bits"][0] == out["unusable_bits"]


def test_a_leap_one_above_the_table_passes_only_after_the_table_is_known_to_end():
    before = LEAP_TABLE_KNOWN_UNTIL_GPS_NS - 86_400 * NS_PER_S
    after = LEAP_TABLE_KNOWN_UNTIL_GPS_NS + 86_400 * NS_PER_S
    common = dict(fix_mode=3, time_valid=True, gdop=1.5, n_sats=9, alarm=False, dissent=False, jump=False,
                  gdop_max=5.0, min_sats=4)
    assert verdict_bits(leap_s=19, t_ns=before, **common) != 0
    assert verdict_bits(leap_s=19, t_ns=after, **common) == 0  # a leap second announced after the table
    assert verdict_bits(leap_s=17, t_ns=after, **common) != 0  # never a count below it


def test_the_log_queries_count_availability_alarms_and_unusable_runs_as_logged(tmp_path):
    from chronofuse.monitor import logquery
    from chronofuse.monitor.log import EpochLog

    bias = _bias(200, 5, Anomaly("ramp", 100.0, rate_s_per_s=50e-9))
    path = tmp_path / "rx.ubx"
    path.write_bytes(ubx_stream(bias))
    log = EpochLog(tmp_path / "log.db")
    acked: list[dict] = []
    Monitor([ReplaySource(path, name="rx", speed=100.0)], KNOWN, log=log, on_ack=acked.extend).run(duration_s=60)
    log.close()
    db = tmp_path / "log.db"
    latched = [r["gps_ns"] for r in acked if r["state"] == "alarm"]
    runs = logquery.intervals(db, "alarm")
    assert int(runs["epochs"].sum()) == len(latched) > 0
    assert int(runs["start_gps_ns"].iloc[0]) == latched[0]
    unusable = logquery.intervals(db, "unusable")
    assert int(unusable["epochs"].sum()) == sum(not r["usable"] for r in acked)
    assert "integrity alarm (latched)" in unusable["reasons"].iloc[-1]
    avail = logquery.availability(db, 20.0)
    assert int(avail["epochs"].sum()) == len(acked) and int(avail["usable"].sum()) == sum(r["usable"] for r in acked)
    full = avail[avail["epochs"] == 20]
    assert (full["expected"] == 20.0).all()
    np.testing.assert_allclose(full["availability"], full["usable"] / 20.0)


def test_a_receiver_that_connects_but_never_gives_an_epoch_is_stale_from_its_link_up(tmp_path):
    from chronofuse.monitor.alerts import AlertHooks
    from chronofuse.monitor.metrics import metrics_text

    rx = TcpReceiver()
    hooked = tmp_path / "hooked.jsonl"
    hooks = AlertHooks(command=f"cat >> {hooked}; echo >> {hooked}")
    events = []

    def on_event(event):
        events.append(event)
        hooks(event)

    mon = Monitor([TcpSource("127.0.0.1", rx.port, name="garbage")], KNOWN, stale_s=1.0, on_event=on_event)
    runner = threading.Thread(target=mon.run, kwargs={"duration_s": 4.0}, daemon=True)
    runner.start()
    try:
        rx.wait_client()
        fresh = status_document(mon)["receivers"][0]
        assert not fresh["stale"]  # not before the stale time has passed
        for _ in range(12):  # bytes that never make an epoch
            rx.send(bytes(range(256)) * 4)
            time.sleep(0.2)
        doc = status_document(mon)
        entry = doc["receivers"][0]
        assert entry["link"] == "up" and entry["stale"] is True and entry["usable"] is None  # was never stale
        assert any(why.startswith("stale: no epoch in") for why in entry["reasons"])
        assert 'chronofuse_receiver_stale{receiver="garbage"} 1.0' in metrics_text(doc).decode()
        stale = [e for e in events if e.kind == "stale"]
        assert len(stale) == 1 and "since the link came up" in stale[0].detail
    finally:
        runner.join(10)
        rx.close()
        hooks.close()
    assert '"kind": "stale"' in hooked.read_text()


def _gps_ns(utc: str) -> int:
    from chronofuse.timescale import utc_to_gps_ns

    return int(utc_to_gps_ns(np.datetime64(utc, "ns")))


def test_a_pending_leap_second_is_checked_against_the_calendar_and_the_table():
    from chronofuse.discipline.verdict import pending_leap_why

    assert pending_leap_why(_gps_ns("2016-12-31T12:00:00"), 17, +1) is None  # the leap second of 2016
    assert "end of June or December" in pending_leap_why(_gps_ns("2024-02-05T03:46:40"), 18, +1)
    assert "end of June or December" in pending_leap_why(_gps_ns("2016-12-20T12:00:00"), 17, +1)  # days too early
    assert "not in the leap-second table" in pending_leap_why(_gps_ns("2015-12-31T12:00:00"), 17, +1)
    assert "not in the leap-second table" in pending_leap_why(_gps_ns("2016-12-31T12:00:00"), 17, -1)
    assert "not in the leap-second table" in pending_leap_why(_gps_ns("2025-12-31T12:00:00"), 18, +1)  # Bulletin C 70
    assert pending_leap_why(_gps_ns("2026-06-30T12:00:00"), 18, +1) is None  # one the table cannot know yet
    assert pending_leap_why(_gps_ns("2024-02-05T03:46:40"), 18, 0) is None
    common = dict(fix_mode=3, time_valid=True, gdop=1.5, n_sats=9, alarm=False, dissent=False, jump=False,
                  gdop_max=5.0, min_sats=4, leap_s=18)
    t = np.array([_gps_ns("2024-02-05T03:46:40"), _gps_ns("2026-06-30T12:00:00")])
    assert verdict_bits(t_ns=t, leap_pending=np.array([1, 1]), **common).tolist()[1] == 0
    assert verdict_bits(t_ns=t, leap_pending=np.array([1, 1]), **common).tolist()[0] != 0


def test_a_bogus_pending_leap_is_not_usable_and_never_sent_to_chronyd(tmp_path):
    from pyubx2 import GET, UBXMessage

    from chronofuse.monitor.chrony import ChronySockFeed

    epochs = ubx_epochs(_bias(40, 8))
    timels = [UBXMessage("NAV", "NAV-TIMELS", GET, iTOW=(100_000 + k) * 1000, version=0, srcOfCurrLs=2, currLs=18,
                         srcOfLsChange=2, lsChange=1, timeToLsEvent=50_000, dateOfLsGpsWn=WEEK, dateOfLsGpsDn=5,
                         validCurrLs=1, validTimeToLsEvent=1).serialize() for k in range(40)]
    streams = {"bogus": b"".join(ls + e for ls, e in zip(timels, epochs)), "honest1": ubx_stream(_bias(40, 9)),
               "honest2": ubx_stream(_bias(40, 10))}
    _, acked = _replay(tmp_path, streams)
    bogus = [r for r in acked if r["receiver"] == "bogus"]
    assert len(bogus) == 40 and all(r["leap_pending"] == 1 for r in bogus)  # February 2024: it cannot be
    assert not any(r["usable"] for r in bogus)  # was fed to chronyd as leap=1
    assert all(any("a leap second comes only at the end of June or December" in why for why in r["reasons"])
               for r in bogus)
    feed = ChronySockFeed(str(tmp_path / "none.sock"))
    by_epoch = {}
    for r in acked:
        by_epoch.setdefault(r["gps_ns"], []).append(r)
    samples = [feed.sample(group) for group in by_epoch.values()]
    assert any(s is not None for s in samples)  # the honest ones feed
    assert all(s[2] == 0 and "bogus" not in s[3] for s in samples if s is not None)
    # two feeding receivers, one announcing: no majority, no leap sent
    pair = [dict(r, leap_pending=p) for r, p in zip(by_epoch[bogus[-1]["gps_ns"]][1:], (1, 0))]
    pair = [dict(r, usable=True, state="ok", dissent=False, jump=False) for r in pair]
    assert feed.sample(pair)[2] == 0


def test_a_receiver_labelling_its_time_a_whole_second_off_dissents_on_arrival(tmp_path):
    # no epoch of it shares a GPS time with the others' as it arrives: the GPS-time vote never saw it
    streams = {"honest1": ubx_stream(_bias(60, 11)), "honest2": ubx_stream(_bias(60, 12)),
               "late": ubx_stream(_bias(60, 13), start_tow_s=100_001)}
    _, acked = _replay(tmp_path, streams)
    late = [r for r in acked if r["receiver"] == "late"]
    assert len(late) == 60 and all(r["dissent"] and r["dissent_s"] == 1 for r in late)  # was dissent 0
    assert not any(r["usable"] for r in late)
    assert all("time dissent: labelled +1 s from the other receivers' time (on arrival)" in r["reasons"] for r in late)
    honest = [r for r in acked if r["receiver"] != "late"]
    assert len(honest) == 120 and not any(r["dissent"] for r in honest)  # the positive control
    assert any(r["usable"] for r in honest)


def _feed(name: str, duration_s: float, epochs: int, seed: int):
    """A monitor of one TCP receiver run for ``duration_s`` on a thread, sent ``epochs`` epochs 0.1 s apart:
    ``(receiver, acknowledged records, the monitor's thread)``."""
    rx = TcpReceiver()
    acked: list[dict] = []
    mon = Monitor([TcpSource("127.0.0.1", rx.port, name=name)], KNOWN, on_ack=acked.extend)
    runner = threading.Thread(target=mon.run, kwargs={"duration_s": duration_s}, daemon=True)
    runner.start()
    rx.wait_client()
    for data in ubx_epochs(_bias(epochs, seed), start_tow_s=200_000):
        rx.send(data)
        time.sleep(0.1)
    return rx, acked, runner


def test_epochs_held_for_a_verdict_are_logged_when_the_link_goes_down_and_when_the_run_ends():
    # 4 epochs, then the receiver hangs up: its grid never learnt its interval (9 epochs), so they were held
    rx, acked, runner = _feed("brief", 4.0, 4, 14)
    try:
        time.sleep(0.5)
        rx.drop()
        deadline = time.monotonic() + 3
        while len(acked) < 4 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert len(acked) == 4, len(acked)  # was 0: held until the end, then dropped
        assert not any(r["usable"] for r in acked)  # never tested: not usable, and says so
    finally:
        runner.join(10)
        rx.close()
    # a receiver still talking when --duration ends: its last epoch (closed by nothing after it) is logged
    rx, acked, runner = _feed("talking", 3.0, 12, 15)
    try:
        runner.join(10)
        assert len(acked) == 12 and acked[-1]["gps_ns"] - acked[0]["gps_ns"] == 11 * NS_PER_S  # was 11
    finally:
        rx.close()
