"""Events once per edge, in the log and on stderr; alert hooks (a shell command and a webhook served by a
real loopback HTTP server) fired once per event; the compact table within 80 and 100 columns."""

from __future__ import annotations

import json
import sqlite3
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import numpy as np
from rich.console import Console

from _real_parts import MonitorProcess
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.io.sources import FileSource
from chronofuse.monitor.decisions import MonitorSettings
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.events import EventTracker
from chronofuse.monitor.table import layout_for, receiver_table

from .conftest import ubx_stream

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=3.0)


def _bias(steps, seed, anomaly=None):
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=seed).measured_s[0]
    return inject(x, anomaly, 1.0) if anomaly is not None else x


def test_an_alarm_held_for_many_epochs_is_one_raised_and_one_cleared_event():
    tracker = EventTracker()
    base = {"receiver": "rx", "dissent": False, "jump": False, "utc": "t"}
    flags = [False] * 5 + [True] * 12 + [False] * 5 + [True] * 3 + [False] * 2
    events = []
    for k, on in enumerate(flags):
        events += tracker.records([dict(base, gps_ns=k * 10**9, alarm=on)], wall_s=1000.0 + k)
    kinds = [e.kind for e in events]
    assert kinds == ["alarm_raised", "alarm_cleared", "alarm_raised", "alarm_cleared"]
    assert [e.gps_ns for e in events] == [5 * 10**9, 17 * 10**9, 22 * 10**9, 25 * 10**9]
    assert events[1].duration_s == 12.0 and events[3].duration_s == 3.0


def test_twenty_failed_reconnections_are_one_outage_with_its_duration():
    tracker = EventTracker()
    out = tracker.link("rx", "up", "", 0.0)
    out += tracker.link("rx", "down", "closed by the other end", 10.0)
    for k in range(20):
        out += tracker.link("rx", "down", "cannot open: refused", 10.5 + k)
    out += tracker.link("rx", "up", "", 42.0)
    assert [e.kind for e in out] == ["link_up", "link_down", "link_up"]
    assert out[1].detail == "closed by the other end"
    assert out[2].duration_s == 32.0 and "20 failed attempt" in out[2].detail


def test_a_silent_receiver_becomes_stale_once_and_fresh_once():
    tracker = EventTracker()
    seen = []
    for t, age in ((0, 0.5), (1, 1.5), (2, 4.0), (3, 6.0), (4, 7.0), (5, 0.2), (6, 0.3)):
        seen += tracker.freshness("rx", age, 5.0, float(t))
    assert [e.kind for e in seen] == ["stale", "fresh"]


class _Hook(BaseHTTPRequestHandler):
    received: list = []

    def do_POST(self):
        body = self.rfile.read(int(self.headers["Content-Length"]))
        type(self).received.append((self.headers["Content-Type"], json.loads(body)))
        self.send_response(204)
        self.end_headers()

    def log_message(self, *args):
        pass


def test_the_alarm_command_and_the_webhook_fire_once_per_alarm_event(tmp_path):
    # two steps far apart: two alarms, each held for several epochs
    bias = _bias(220, seed=3, anomaly=Anomaly("step", 90.0, offset_s=500e-9))
    bias = inject(bias, Anomaly("step", 170.0, offset_s=-500e-9), 1.0)
    recording = tmp_path / "stepped.ubx"
    recording.write_bytes(ubx_stream(bias))
    _Hook.received = []
    server = ThreadingHTTPServer(("127.0.0.1", 0), _Hook)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    fired = tmp_path / "fired.jsonl"
    db = tmp_path / "log.db"
    proc = MonitorProcess(["--replay", str(recording), "--replay-speed", "200", "--train", "60", "--db", str(db),
                           "--on-alarm", f"cat >> {fired}; echo >> {fired}", "--webhook",
                           f"http://127.0.0.1:{server.server_address[1]}/hook", "--no-table"], tmp_path)
    try:
        proc.proc.wait(120)
    finally:
        proc.stop()
        server.shutdown()
    assert proc.proc.returncode == 0, proc.stderr()
    con = sqlite3.connect(db)
    raised = con.execute("SELECT receiver, kind, gps_ns FROM events WHERE kind = 'alarm_raised' ORDER BY id").fetchall()
    alarm_epochs = con.execute("SELECT COUNT(*) FROM epochs WHERE alarm = 1").fetchone()[0]
    assert len(raised) == 2 and alarm_epochs > 2 * 2  # two events, many alarm epochs
    from_command = [json.loads(line) for line in fired.read_text().splitlines() if line.strip()]
    assert [(e["receiver"], e["kind"], e["gps_ns"]) for e in from_command] == [tuple(r) for r in raised]
    assert [(b["receiver"], b["kind"], b["gps_ns"]) for _, b in _Hook.received] == [tuple(r) for r in raised]
    assert {kind for kind, _ in _Hook.received} == {"application/json"}
    # the events are lines on stderr too
    lines = [line for line in proc.stderr().splitlines() if " alarm_raised" in line]
    assert len(lines) == 2 and all("stepped.ubx" in line for line in lines)


def test_the_table_fits_80_and_100_columns_and_keeps_names_and_utc_readable(tmp_path):
    sources = []
    for name in ("ublox-zed-f9p_hpg1.11.log#1", "u-blox-m8t-time.log#0", "rx3"):
        path = tmp_path / f"{name}.ubx"
        path.write_bytes(ubx_stream(_bias(30, seed=len(name))))
        sources.append(FileSource(path, name=name))
    mon = Monitor(sources, MonitorSettings(train_s=200.0))
    mon.run(duration_s=30)
    for width in (80, 100):
        console = Console(record=True, width=width, force_terminal=False)
        console.print(receiver_table(mon, width=width))
        text = console.export_text()
        assert max(len(line) for line in text.splitlines()) <= width, text
        assert "ublox-ze" in text and ".log#1" in text  # shortened in the middle, both ends kept
        assert "rx3" in text
        last = mon.receivers["rx3"].last
        assert f"{last['clock_bias_s'] * 1e9:.1f}" in text  # the clock bias whole
        if width >= 100:
            assert last["utc"][11:19] in text  # the UTC time of day whole
    assert "utc_time" in layout_for(100) and "utc_time" not in layout_for(80)
    assert np.all([c in layout_for(80) for c in ("receiver", "ok", "bias", "why")])


def test_hooks_fire_concurrently_so_a_hanging_command_neither_delays_nor_drops_a_webhook(tmp_path):
    from chronofuse.monitor.alerts import AlertHooks
    from chronofuse.monitor.events import MonitorEvent

    _Hook.received = []
    server = ThreadingHTTPServer(("127.0.0.1", 0), _Hook)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    failures = []
    hooks = AlertHooks(command="sleep 1000", webhook=f"http://127.0.0.1:{server.server_address[1]}/hook",
                       timeout_s=2.0, on_error=lambda ev, why: failures.append((ev.receiver, why)))
    start = time.monotonic()
    try:
        for k in range(6):  # six stale events at once
            hooks(MonitorEvent(f"rx{k}", "stale", 1_700_000_000.0 + k, "no epoch for 6.0 s"))
        deadline = time.monotonic() + 5
        while len(_Hook.received) < 6 and time.monotonic() < deadline:
            time.sleep(0.02)
        posted_s = time.monotonic() - start
        assert len(_Hook.received) == 6 and posted_s < 1.5, posted_s  # were 20 s late, 4 of 6 never posted
        hooks.close()  # waits for the commands' own time limit, not one after another
        closed_s = time.monotonic() - start
        assert closed_s < 2.0 + 2.5, closed_s  # was 6 x 10 s in series
        assert sorted(r for r, why in failures) == [f"rx{k}" for k in range(6)]
        assert all("timed out after 2 s" in why for _, why in failures)
        assert hooks.fired == 6 and hooks.failed == 6
    finally:
        server.shutdown()
        server.server_close()
