"""The monitor: decisions from the disciplined oscillator's qualification and consensus code and the HOD
detector's streaming step, records acknowledged only once committed, a session report."""

from __future__ import annotations

import sqlite3

import numpy as np

from chronofuse.discipline.qualification import Qualification, usable_epochs
from chronofuse.integrity.detector import HodDetector
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias
from chronofuse.io.inspect import read_bytes, read_capture
from chronofuse.io.sources import FileSource
from chronofuse.io.sources_decode import split_rows
from chronofuse.monitor.decisions import MonitorSettings, ReceiverMonitor, decide_second
from chronofuse.monitor.engine import Monitor
from chronofuse.monitor.log import EpochLog
from chronofuse.monitor.summary import read_session

from .conftest import receivers_dir, ubx_stream

NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=3.0)
SETTINGS = MonitorSettings(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m, train_s=60.0)


def _bias(steps: int, seed: int, anomaly: Anomaly | None = None) -> np.ndarray:
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=seed).measured_s[0]
    return inject(x, anomaly, 1.0) if anomaly is not None else x


def _run(tmp_path, streams: dict[str, bytes], settings=SETTINGS, **kw):
    sources = []
    for name, data in streams.items():
        path = tmp_path / f"{name}.ubx"
        path.write_bytes(data)
        sources.append(FileSource(path, name=name, chunk=997))
    log = EpochLog(tmp_path / "log.db")
    acked: list[dict] = []
    mon = Monitor(sources, settings, log=log, on_ack=acked.extend, **kw)
    mon.run(duration_s=60)
    log.close()
    return mon, acked


def test_usable_is_the_disciplined_oscillators_qualification_of_the_same_epochs(tmp_path):
    capture = read_capture(receivers_dir() / "gpsd" / "u-blox-m8t-time.log")
    batch = usable_epochs(capture.epochs, Qualification(5.0, 4))[0, 0]
    rx = ReceiverMonitor("m8t", MonitorSettings())
    live = [rx.decide(epoch)["usable"] for epoch in split_rows(capture.rows)]
    assert isinstance(rx.qualification, Qualification)
    assert live == batch.tolist()


def test_an_injected_clock_bias_step_raises_the_hod_alarm_the_batch_detector_raises(tmp_path):
    bias = _bias(400, seed=7, anomaly=Anomaly("step", 300.0, offset_s=400e-9))
    mon, acked = _run(tmp_path, {"rx": ubx_stream(bias)})
    alarms = [r["gps_ns"] for r in acked if r["alarm"]]
    first = acked[0]["gps_ns"]
    assert alarms and min(alarms) == first + 300 * 10**9  # the step is caught the epoch it happens
    # the same detector, fitted the same way, run in batch over the same (ns-quantized) biases
    logged = np.array([r["clock_bias_s"] for r in acked])
    det = HodDetector(interval_s=1.0, window=20, pfa=1e-3, h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=NOISE.sigma_rho_m)
    det.fit(logged[1:61])
    for x in logged[31:61]:
        det.step(x)
    batch = [det.step(x).alarm for x in logged[61:]]
    assert [r["alarm"] for r in acked[61:]] == batch


def test_every_acknowledged_record_is_already_committed(tmp_path):
    seen_in_db = []
    db_path = tmp_path / "log.db"
    path = tmp_path / "rx.ubx"
    path.write_bytes(ubx_stream(_bias(80, seed=3)))

    def ack(records):
        reader = sqlite3.connect(db_path)
        rows = set(reader.execute("SELECT receiver, gps_ns FROM epochs").fetchall())
        reader.close()
        seen_in_db.append(all((r["receiver"], r["gps_ns"]) in rows for r in records))

    log = EpochLog(db_path)
    Monitor([FileSource(path, name="rx", chunk=300)], SETTINGS, log=log, on_ack=ack).run(duration_s=60)
    log.close()
    assert seen_in_db and all(seen_in_db)


def test_a_receiver_with_a_wrong_leap_count_is_outvoted_and_flagged():
    base = {"fix_mode": 3, "time_valid": True, "leap_pending": 0, "clock_bias_s": float("nan")}
    records = [dict(base, receiver=f"r{i}", gps_ns=1_391_040_000 * 10**9, leap_s=18) for i in range(3)]
    records[2]["leap_s"] = 17
    decide_second(records, 100e-9, {})
    assert [r["dissent"] for r in records] == [False, False, True]


def test_an_offset_jump_of_one_receiver_is_flagged_and_a_common_move_is_not():
    previous = {"a": 0.0, "b": 0.0, "c": 0.0}
    base = {"fix_mode": 3, "time_valid": True, "leap_pending": 0, "leap_s": 18, "gps_ns": 10**18}
    records = [dict(base, receiver=n, clock_bias_s=b) for n, b in (("a", 50e-9), ("b", 52e-9), ("c", 800e-9))]
    decide_second(records, 100e-9, previous)
    assert [r["jump"] for r in records] == [False, False, True]


def test_two_receivers_logged_together_share_their_epochs_and_the_report_reads_them_back(tmp_path):
    streams = {"a": ubx_stream(_bias(90, seed=1)), "b": ubx_stream(_bias(90, seed=2))}
    mon, acked = _run(tmp_path, streams)
    assert len(acked) == 180
    sessions = {s.name: s for s in read_session(tmp_path / "log.db")}
    assert set(sessions) == {"a", "b"}
    np.testing.assert_array_equal(sessions["a"].gps_ns, sessions["b"].gps_ns)
    expected = read_bytes([streams["a"]]).rows["clock_bias_s"]
    np.testing.assert_allclose(sessions["a"].clock_bias_s, expected)
    assert sessions["a"].adev is not None and np.all(np.isfinite(sessions["a"].adev.dev[:3]))


def test_the_live_table_shows_each_receiver_its_alarm_and_its_clock_bias(tmp_path):
    from rich.console import Console

    from chronofuse.monitor.table import receiver_table

    bias = _bias(200, seed=7, anomaly=Anomaly("step", 199.0, offset_s=400e-9))
    mon, acked = _run(tmp_path, {"rx": ubx_stream(bias), "quiet": ubx_stream(_bias(200, seed=8))})
    console = Console(record=True, width=220)
    console.print(receiver_table(mon))
    text = console.export_text()
    rows = {line.split()[0]: line for line in text.splitlines() if line.split() and line.split()[0] in ("rx", "quiet")}
    assert set(rows) >= {"rx", "quiet"}
    assert "ALARM" in rows["rx"] and "ALARM" not in rows["quiet"]
    assert f"{acked[-1]['clock_bias_s'] * 1e9:.1f}" in text
