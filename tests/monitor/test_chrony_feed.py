"""The chrony feed with a real chronyd (Debian's, ``-x``: it never touches the system clock): a replayed
recording fed through the SOCK refclock is a source chronyd sees (``chronyc sources``/``sourcestats``);
with an alarm injected into the stream the samples stop. The datagram layout is checked against the
struct chrony reads."""

from __future__ import annotations

import re
import struct
import time

import numpy as np
import pytest

from _real_parts import Chronyd, MonitorProcess
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.monitor.chrony import SOCK_MAGIC, ChronySockFeed, feeding, sock_sample

from .conftest import receivers_dir, ubx_stream

M8T = receivers_dir() / "gpsd" / "u-blox-m8t-time.log"  # a timing receiver without NAV-CLOCK: never tested
NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=3.0)
KNOWN = ["--h0", str(NOISE.h0), "--hm2", str(NOISE.hm2), "--sigma-rho", str(NOISE.sigma_rho_m)]


def test_a_sock_sample_is_the_40_byte_struct_chrony_reads():
    data = sock_sample(1_700_000_000_123_456_789, -0.25, leap=1)
    assert len(data) == 40
    sec, usec, offset, pulse, leap, _pad, magic = struct.unpack("qqdiiii", data)
    assert (sec, usec, offset, pulse, leap, magic) == (1_700_000_000, 123_456, -0.25, 0, 1, SOCK_MAGIC)


def _record(name, **kw):
    base = {"receiver": name, "gps_ns": 1_391_040_000 * 10**9, "leap_s": 18, "leap_pending": 0, "usable": True,
            "state": "ok", "alarm": False, "dissent": False, "jump": False, "received_unix_ns": 1_706_000_000 * 10**9}
    return {**base, **kw}


@pytest.mark.parametrize("flag", ["alarm", "dissent", "jump"])
def test_a_receiver_in_alarm_dissenting_or_jumping_does_not_feed(flag):
    assert feeding(_record("a"))
    assert not feeding(_record("a", **{flag: True}))
    assert not feeding(_record("a", usable=False))
    assert not feeding(_record("a"), stale=True)


@pytest.mark.parametrize("state", ["unavailable", "alarm", None])
def test_a_receiver_the_integrity_test_has_not_found_ok_does_not_feed(state):
    # training, a failed training, no clock bias: never checked, never fed, even if marked usable
    assert not feeding(_record("a", state=state))


def test_the_fused_sample_is_the_median_receivers_and_a_pps_edge_outranks_message_times(tmp_path):
    feed = ChronySockFeed(str(tmp_path / "none.sock"))
    utc_unix_ns = (1_391_040_000 - 18 + 315_964_800) * 10**9
    group = [_record(n, received_unix_ns=utc_unix_ns + lat) for n, lat in (("a", 80_000_000), ("b", 95_000_000),
                                                                         ("c", 900_000_000))]
    tv, offset, leap, names = feed.sample(group)
    assert (tv, names, leap) == (utc_unix_ns + 95_000_000, ["a", "b", "c"], 0)
    assert offset == pytest.approx(-0.095)  # the median latency: the 0.9 s outlier does not move it
    group[0]["pps_unix_ns"] = utc_unix_ns + 1_500  # a PPS edge 1.5 us after the second
    tv, offset, _, names = feed.sample(group)
    assert names == ["a"] and offset == pytest.approx(-1.5e-6)
    group[0]["alarm"] = True  # the receiver with the edge alarms: back to the message times of the others
    assert feed.sample(group)[3] == ["b", "c"]
    for r in group:
        r["leap_pending"] = 1
    assert feed.sample(group)[2] == 1  # an announced insertion is chrony's leap 1


def _wait_for(chrony: Chronyd, predicate, timeout_s: float):
    deadline = time.monotonic() + timeout_s
    state = None
    while time.monotonic() < deadline:
        state = chrony.source()
        if predicate(state):
            return state
        time.sleep(0.5)
    raise AssertionError(f"chronyd's CFSE source never got there: {state}")


@pytest.mark.slow
def test_chronyd_sees_a_replayed_recording_fed_through_its_sock_refclock(tmp_path):
    # a receiver with a clock bias, its noise model given (no training stretch): tested, so fed, from the
    # epoch its detector's window is full (the M8T capture has no clock bias: nothing of it is fed)
    bias = simulate_clock_bias(NOISE, interval_s=1.0, steps=60, trials=1, seed=3).measured_s[0]
    recording = tmp_path / "tested.ubx"
    recording.write_bytes(ubx_stream(bias))
    chrony = Chronyd(poll=2)
    proc = MonitorProcess(["--replay", str(recording), "--replay-speed", "1", *KNOWN, "--window", "8",
                           "--chrony-sock", str(chrony.refclock), "--duration", "40", "--no-table"], tmp_path)
    try:
        state = _wait_for(chrony, lambda s: s["samples"] >= 1 and s["reach"] > 0, 60)
        # the replay's own timing, shifted to now by whole seconds: offsets well inside a second
        assert abs(state["last_offset_s"]) < 1.0
        text = chrony.chronyc("sources")
        assert re.search(r"^#. CFSE\s", text, re.M), text
    finally:
        proc.stop()
        chrony.close()


@pytest.mark.slow
def test_with_an_injected_alarm_the_samples_to_chronyd_stop(tmp_path):
    bias = simulate_clock_bias(NOISE, interval_s=1.0, steps=80, trials=1, seed=5).measured_s[0]
    bias = inject(bias, Anomaly("step", 24.0, offset_s=2e-6), 1.0)  # a 2 us clock step at epoch 24
    recording = tmp_path / "stepped.ubx"
    recording.write_bytes(ubx_stream(bias))
    chrony = Chronyd(poll=2)  # polls every 4 s: two polls in the 9.5 s of alarm, the second past every sample
    proc = MonitorProcess(["--replay", str(recording), "--replay-speed", "1", "--train", "16", "--window", "12",
                           "--chrony-sock", str(chrony.refclock), "--no-table", "--duration", "90"], tmp_path)
    try:
        before = _wait_for(chrony, lambda s: s["samples"] >= 1, 60)
        assert before["last_rx_s"] <= 16  # samples arrive every second, chrony takes them every 4 s
        proc.wait_for_stderr(r"stepped\.ubx alarm_raised", 40)
        raised = time.monotonic()
        at_alarm = chrony.source()
        time.sleep(9.5)
        assert "alarm_cleared" not in proc.stderr()  # still in alarm (the window holds the step 12 epochs)
        during = chrony.source()
        # no sample since the alarm: chrony's last sample is older than the time spent in alarm
        assert during["last_rx_s"] >= time.monotonic() - raised - 1.5, (before, during)
        # at most the samples sent before the alarm and taken at chrony's next poll (every 4 s)
        assert during["samples"] <= at_alarm["samples"] + 1, (at_alarm, during)
        assert during["reach"] & 0b1 == 0, (before, at_alarm, during)  # its last poll found no sample
    finally:
        proc.stop()
        chrony.close()
