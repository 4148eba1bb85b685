"""A time tag with odd nanoseconds survives every input path to every output: integer nanoseconds from the
text (or the receiver's message) to the JSON documents, the JSON lines, the human tables and the monitor's
records and log, never through one float64 (a float64 of today's UNIX seconds steps by 238 ns; the old
clock-bias CSV path lost 123 ns of such a tag, the old stream parser 256 ns).

The oracle is the tag as written: every time an output gives must be the written tag plus a whole number of
intervals, to the nanosecond."""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import subprocess
import sys
import threading
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import detect as detect_cli
from chronofuse.cli import monitor as monitor_cli
from chronofuse.integrity.inject import Anomaly, inject
from chronofuse.integrity.simulate import ClockNoise, simulate_clock_bias

from _recordings import ubx_recording  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
NOISE = ClockNoise(h0=2e-18, hm2=1e-22, sigma_rho_m=1.0)
MODEL = ["--h0", "2e-18", "--hm2", "1e-22", "--sigma-rho", "1"]
T0_NS = 1_700_000_000_123_456_789  # UNIX ns: odd nanoseconds, far beyond a float64's resolution of seconds
STEP_AT = 300
runner = CliRunner()
app = typer.Typer()
detect_cli.register(app)
monitor_cli.register(app)


@app.callback()
def _root() -> None:
    """Local app holding the commands under test."""


def _bias(steps: int = 500) -> np.ndarray:
    x = simulate_clock_bias(NOISE, interval_s=1.0, steps=steps, trials=1, seed=21).measured_s[0]
    return inject(x, Anomaly("step", float(STEP_AT), offset_s=1e-7), 1.0)


def _seconds_text(t_ns: int) -> str:
    whole, frac = divmod(t_ns, 10**9)
    return f"{whole}.{frac:09d}"


def _on_grid(times, t0_ns: int = T0_NS, interval_ns: int = 10**9) -> bool:
    return all(isinstance(t, int) and (t - t0_ns) % interval_ns == 0 for t in times)


def _doc_times(doc: dict) -> list[int]:
    return ([a["t_ns"] for a in doc["alarms"]] + [e["t_ns"] for e in doc["alarm_events"]]
            + [e["t_ns"] for e in doc["clock_events"]]
            + [u[k] for u in doc["unavailable"] for k in ("from_ns", "to_ns")])


def _csv(path: Path, time_name: str, time_text) -> Path:
    x = _bias()
    path.write_text(f"{time_name},clock_bias_s\n" + "".join(f"{time_text(k)},{float(v)!r}\n" for k, v in enumerate(x)))
    return path


def test_a_csv_of_unix_seconds_keeps_its_nanoseconds_to_the_json_document_and_the_human_table(tmp_path):
    path = _csv(tmp_path / "unix.csv", "t_s", lambda k: _seconds_text(T0_NS + k * 10**9))
    doc = json.loads(runner.invoke(app, ["detect", str(path), "--json", *MODEL]).stdout)
    assert doc["time_scale"] == "file" and doc["alarms"]
    assert _on_grid(_doc_times(doc)) and doc["alarms"][0]["t_ns"] == T0_NS + STEP_AT * 10**9
    human = runner.invoke(app, ["detect", str(path), *MODEL]).stdout
    assert _seconds_text(T0_NS + STEP_AT * 10**9) in human  # the alarm table's time, every digit


def test_the_same_csv_piped_into_detect_keeps_its_nanoseconds_in_every_json_line(tmp_path):
    path = _csv(tmp_path / "unix.csv", "t_s", lambda k: _seconds_text(T0_NS + k * 10**9))
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    with open(path, "rb") as stdin:
        out = subprocess.run([sys.executable, "-m", "chronofuse.cli.main", "detect", "-", "--json-lines", *MODEL],
                             stdin=stdin, capture_output=True, env=env, timeout=300)
    lines = [json.loads(line) for line in out.stdout.decode().splitlines()]
    assert out.returncode == 1 and [r["t_ns"] for r in lines] == [T0_NS + k * 10**9 for k in range(500)]
    assert [r["t_ns"] for r in lines if r["alarm"]][0] == T0_NS + STEP_AT * 10**9


def test_a_nanosecond_time_column_and_an_mjd_column_give_the_same_exact_tags(tmp_path):
    ns = _csv(tmp_path / "ns.csv", "t_ns", lambda k: str(T0_NS + k * 10**9))
    # MJD in days with 17 decimals: the text's value is within 1e-17 days (0.9 ps) of the tag
    mjd0 = 40587  # MJD of 1970-01-01: the same instants as the UNIX tags above, on the MJD axis
    mjd = _csv(tmp_path / "mjd.csv", "mjd", lambda k: _decimal(Fraction(mjd0) + Fraction(T0_NS + k * 10**9,
                                                                                        86_400 * 10**9), 17))
    a = json.loads(runner.invoke(app, ["detect", str(ns), "--json", *MODEL]).stdout)
    b = json.loads(runner.invoke(app, ["detect", str(mjd), "--json", *MODEL]).stdout)
    assert _on_grid(_doc_times(a)) and a["alarms"][0]["t_ns"] == T0_NS + STEP_AT * 10**9
    shift = mjd0 * 86_400 * 10**9
    assert [t - shift for t in _doc_times(b)] == _doc_times(a)


def _decimal(value: Fraction, digits: int) -> str:
    """``value`` written with ``digits`` decimals, rounded (exact rational arithmetic, no float)."""
    scaled = round(value * 10**digits)
    whole, frac = divmod(scaled, 10**digits)
    return f"{whole}.{frac:0{digits}d}"


def test_the_stability_reader_keeps_the_tags_and_its_epoch_record_too(tmp_path):
    from chronofuse.io.records import epoch_record, read_record

    path = _csv(tmp_path / "unix.csv", "t_s", lambda k: _seconds_text(T0_NS + k * 10**9))
    record = read_record(path, kind="phase")
    assert record.t_ns.dtype == np.int64 and record.t_ns[0] == T0_NS and np.all(np.diff(record.t_ns) == 10**9)
    np.testing.assert_array_equal(epoch_record(record).t_ns, record.t_ns)


RINEX_CLOCK_HEAD = ("     3.00           C                                       RINEX VERSION / TYPE\n"
                    "                                                            END OF HEADER\n")


def _clock_product(path: Path, micro: int = 123_457) -> tuple[Path, int]:
    """A RINEX clock product of one station at 30 s whose epochs carry an odd number of microseconds."""
    from chronofuse.timescale import datetime64_to_gps_ns

    x = _bias(400)
    lines = []
    for k, v in enumerate(x):
        minute, sec = divmod(30 * k, 60)
        hour, minute = divmod(minute, 60)
        lines.append(f"AR ODDS 2024 02 04 {hour:2d} {minute:2d} {sec:2d}.{micro:06d}  1   {v:.12e}\n")
    path.write_text(RINEX_CLOCK_HEAD + "".join(lines))
    t0 = int(datetime64_to_gps_ns(np.datetime64("2024-02-04T00:00:00", "ns"))) + micro * 1000
    return path, t0


def test_a_clock_products_odd_microseconds_survive_detect_its_stream_and_the_monitor(tmp_path):
    path, t0 = _clock_product(tmp_path / "odd.clk")
    args = ["--window", "5", *MODEL]
    doc = json.loads(runner.invoke(app, ["detect", str(path), "--station", "ODDS", "--json", *args]).stdout)
    assert doc["time_scale"] == "gps" and doc["alarms"] and _on_grid(_doc_times(doc), t0, 30 * 10**9)
    streamed = runner.invoke(app, ["detect", "-", "--json-lines", *args], input=path.read_bytes())
    times = [json.loads(line)["t_ns"] for line in streamed.stdout.splitlines()]
    assert times == [t0 + k * 30 * 10**9 for k in range(400)]
    db = tmp_path / "log.db"
    mon = runner.invoke(app, ["monitor", "--replay", str(path), "--replay-speed", "1e6", "--json-lines", "--db", str(db),
                              *args])
    records = [json.loads(line) for line in mon.stdout.splitlines()]
    assert [r["gps_ns"] for r in records] == times
    assert all(r["utc"].endswith(".123457000Z") for r in records)  # the UTC label keeps the microseconds
    logged = [row[0] for row in sqlite3.connect(db).execute("SELECT gps_ns FROM epochs ORDER BY gps_ns")]
    assert logged == times


def test_ubx_time_of_week_in_odd_milliseconds_reaches_the_documents_exactly(tmp_path):
    from _recordings import WEEK

    path = tmp_path / "odd.ubx"
    start_tow_ms = 100_000_123  # iTOW is in ms: 123 ms past the second
    path.write_bytes(ubx_recording(_bias(400), start_tow_ms=start_tow_ms))
    doc = json.loads(runner.invoke(app, ["detect", str(path), "--json", *MODEL]).stdout)
    t0 = WEEK * 604_800 * 10**9 + start_tow_ms * 10**6
    assert doc["time_scale"] == "gps" and doc["alarms"][0]["t_ns"] == t0 + STEP_AT * 10**9
    assert _on_grid(_doc_times(doc), t0)
    mon = runner.invoke(app, ["monitor", "--replay", str(path), "--replay-speed", "1e6", "--json-lines", *MODEL])
    records = [json.loads(line) for line in mon.stdout.splitlines()]
    assert [r["gps_ns"] for r in records] == [t0 + k * 10**9 for k in range(400)]
    assert [r["gps_ns"] for r in records if r["alarm"]] == [a["t_ns"] for a in doc["alarms"]]


def test_gpsd_reports_with_nanosecond_times_keep_them_in_the_monitors_records(tmp_path):
    reports = b"".join(
        json.dumps({"class": "TPV", "mode": 3, "time": f"2024-02-04T00:00:{k:02d}.123456789Z", "leapseconds": 18}
                   ).encode() + b"\n" for k in range(20))
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen()
    port = server.getsockname()[1]

    def serve():
        conn, _ = server.accept()
        conn.recv(100)
        conn.sendall(b'{"class":"VERSION","release":"3.25"}\n' + reports)
        conn.close()

    threading.Thread(target=serve, daemon=True).start()
    from chronofuse.io.sources import Backoff, GpsdSource
    from chronofuse.monitor.decisions import MonitorSettings
    from chronofuse.monitor.engine import Monitor
    from chronofuse.timescale import datetime64_to_gps_ns

    acked = []
    mon = Monitor([GpsdSource("127.0.0.1", port, backoff=Backoff(30.0))], MonitorSettings(), on_ack=acked.extend)
    mon.run(duration_s=8)
    server.close()
    t0 = int(datetime64_to_gps_ns(np.datetime64("2024-02-04T00:00:00.123456789", "ns"))) + 18 * 10**9
    got = [r["gps_ns"] for r in acked]
    assert got[:19] == [t0 + k * 10**9 for k in range(19)]
    assert all(r["utc"].endswith(".123456789Z") for r in acked)


def test_a_simulated_receivers_epochs_keep_their_grid_in_the_record_and_through_the_clock_watch():
    from chronofuse.integrity.watch import ClockWatch, DetectionSettings
    from chronofuse.record import EpochRecord

    t = T0_NS + np.arange(400, dtype=np.int64) * 10**9
    record = EpochRecord.from_arrays(t, {"clock_bias_s": _bias(400)}, {"clock_bias_s": "s"}, source="simulated",
                                     interval_ns=10**9, time_scale="file")
    verdicts = ClockWatch(DetectionSettings(h0=NOISE.h0, hm2=NOISE.hm2, sigma_rho_m=1.0)).push(record)
    assert [v.t_ns for v in verdicts] == t.tolist()
    assert [v.t_ns for v in verdicts if v.alarm][0] == T0_NS + STEP_AT * 10**9


@pytest.mark.parametrize("chunk", [1, 7, 4096])
def test_a_receiver_simulation_becomes_a_record_with_its_gps_nanoseconds(chunk):
    from chronofuse.epochs import ReceiverEpochs
    from chronofuse.record import EpochRecord

    fields = ReceiverEpochs.absent(T0_NS + np.arange(30, dtype=np.int64) * 10**9, 2, 3, leap_s=18)
    epochs = ReceiverEpochs(**fields)
    record = epochs.to_record("simulated")
    parts = list(record.chunks(chunk))
    assert EpochRecord.concat(parts).t_ns.tolist() == epochs.gps_ns.tolist() and record.lead == (2, 3)
    back = ReceiverEpochs.from_record(record)
    np.testing.assert_array_equal(back.gps_ns, epochs.gps_ns)
    np.testing.assert_array_equal(back.leap_s, epochs.leap_s)


def _dicts(node):
    if isinstance(node, dict):
        yield node
        node = list(node.values())
    if isinstance(node, list):
        for item in node:
            yield from _dicts(item)


def test_every_time_a_document_gives_in_seconds_comes_with_its_exact_nanoseconds(tmp_path, real_data):
    # "t" (seconds, a float: a convenience that loses odd nanoseconds of an absolute time) never stands alone:
    # beside it "t_ns" holds the exact integer, in the detection document and in a clock product's table
    path = _csv(tmp_path / "unix.csv", "t_s", lambda k: _seconds_text(T0_NS + k * 10**9))
    docs = [json.loads(runner.invoke(app, ["detect", str(path), "--json", *MODEL]).stdout),
            json.loads(runner.invoke(app, ["detect", str(real_data / "receivers/rinex/rtklib/igs15904.clk"), "--json",
                                           "--window", "5", *MODEL]).stdout)]
    timed = [d for doc in docs for d in _dicts(doc) if "t" in d]
    assert len(timed) > 5
    for d in timed:
        assert isinstance(d["t_ns"], int) and d["t"] == d["t_ns"] / 1e9, d
    lossy = [d for d in timed if round(d["t"] * 1e9) != d["t_ns"]]
    assert lossy  # the float does lose them (why t_ns is there): the CSV's tags have odd nanoseconds
