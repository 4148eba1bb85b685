"""One program on every path: for every recording in tests/data that carries a clock bias, and for simulated
recordings with a millisecond reset, a step, a ramp and a fix loss, ``detect FILE``, ``detect -`` (the bytes
piped into a real process) and ``monitor --replay`` give the same alarms, states and clock events.

The oracle is the batch document of ``detect FILE --json``; ``detect - --json-lines`` must give, epoch by
epoch, the alarms, the raises and clears and the clock resets that document lists, and ``monitor --replay
--json-lines`` the same state, alarm and events for every epoch the receiver logged. ``detect -`` without
``--json-lines`` must print the very document ``detect FILE`` prints (library level, the same driver).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import detect as detect_cli
from chronofuse.cli import monitor as monitor_cli

from _helpers import receivers_dir  # noqa: E402
from _recordings import SIMULATED  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
RX = receivers_dir()
MODEL = ["--h0", "2e-18", "--hm2", "1e-22", "--sigma-rho", "1"]
runner = CliRunner()
app = typer.Typer()
detect_cli.register(app)
monitor_cli.register(app)


@app.callback()
def _root() -> None:
    """Local app holding the commands under test."""


# Every recording of tests/data whose clock bias chronofuse reads (UBX NAV-CLOCK, RINEX clock products), with
# the options detect runs it with: (window, training stretch in s or None for the given noise model, extra).
# A recording too short for its window is refused alike on both detect paths (and the monitor logs it untested).
REAL = {
    "gpsd/navisys-gr701w.log": (10, None, []),
    "gpsd/navisys-gr8013.log": (10, None, []),
    "gpsd/ublox-aek-4t.log": (1, None, []),
    "gpsd/ublox-lea-4t.log": (1, None, ["--rate", "1"]),
    "gpsd/ublox-neo-f9v.log": (2, None, []),
    "gpsd/ublox-zed-f9p_hpg1.11.log": (20, 300, []),
    "gpsd/ublox-zed-f9p_hpg1.11.log.gz": (10, 300, []),
    "gpsd/ublox-zed-f9r.log": (5, None, []),
    "gpsd/ublox-zed-f9t-ubx_nmea_l5.log": (5, None, []),
    "rinex/gnss_lib_py/COD0MGXFIN_20211180000_01D_30S_CLK.CLK": (5, None, ["--pfa", "0.01"]),
    "rinex/gnss_lib_py/COD0OPSRAP_20230730000_01D_30S_CLK.CLK": (5, None, []),
    "rinex/gnss_lib_py/grg21553.clk": (5, None, ["--pfa", "0.01"]),
    "rinex/gnss_lib_py/grg21553.clk.gz": (5, None, []),
    "rinex/rtklib/igs15904.clk": (5, None, []),
    "rinex/rtklib/igs15904.clk.gz": (3, None, []),
    "ubx/mon_span.ubx": (1, None, []),
    "ubx/pygpsdata-BADCK2.log": (20, None, ["--rate", "1"]),
    "ubx/pygpsdata-NAV-ZED-X20P.log": (1, None, []),
    "ubx/pygpsdata-NAV.log": (20, None, []),
}


def test_the_list_holds_every_recording_with_a_clock_bias():
    import gzip

    import numpy as np

    from chronofuse.io.inspect import read_capture

    found = set()
    for path in sorted(RX.rglob("*")):
        if path.is_dir() or ".chk" in path.name:
            continue
        data = path.read_bytes()
        if data[:2] == b"\x1f\x8b":
            data = gzip.decompress(data)
        # the bytes of a UBX NAV-CLOCK frame (sync, class 0x01, id 0x22) or a RINEX clock product's AR record
        if b"\xb5\x62\x01\x22" not in data and not (b"RINEX VERSION" in data[:100] and b"\nAR " in data):
            continue
        if np.isfinite(read_capture(path).rows["clock_bias_s"]).any():
            found.add(str(path.relative_to(RX)))
    assert found == set(REAL)


def _pipe(path: Path, args: list[str]) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    with open(path, "rb") as stdin:
        return subprocess.run([sys.executable, "-m", "chronofuse.cli.main", "detect", "-", "--json-lines", *args],
                              stdin=stdin, capture_output=True, env=env, timeout=600)


def _events(lines: list[dict]):
    alarms = [(r.get("station"), r["t_ns"]) for r in lines if r["alarm"]]
    resets = [(r.get("station"), r["t_ns"]) for r in lines for e in r["events"] if e.startswith("clock reset")]
    latch = [(r.get("station"), r["t_ns"], e.split(":")[0]) for r in lines for e in r["events"]
             if e.startswith(("raise", "clear"))]
    return alarms, resets, latch


def _doc_events(doc: dict, station=None):
    alarms = [(station, a["t_ns"]) for a in doc["alarms"]]
    resets = [(station, e["t_ns"]) for e in doc["clock_events"]]
    latch = [(station, e["t_ns"], e["kind"]) for e in doc["alarm_events"]]
    return alarms, resets, latch


def _check_paths(path: Path, args: list[str], monitor_args: list[str] | None, tmp_path: Path):
    batch = runner.invoke(app, ["detect", str(path), "--json", *args])
    piped = _pipe(path, args)
    assert piped.returncode == batch.exit_code, (piped.stderr, batch.output)
    if batch.exit_code == 2:  # bad input: the same one-line error on both paths (the source named as each sees it)
        assert batch.stderr.replace(str(path), "<stdin>") == piped.stderr.decode(), (batch.stderr, piped.stderr)
        return None
    doc = json.loads(batch.stdout)
    lines = [json.loads(line) for line in piped.stdout.decode().splitlines()]
    if doc["mode"] == "clock-product":
        by_station = {}
        for r in lines:
            by_station.setdefault(r["station"], []).append(r)
        for row in doc["stations"]:
            got = by_station.get(row["station"], [])
            assert sum(r["alarm"] for r in got) == row["n_alarms"], row["station"]
            assert [r["t_ns"] for r in got for e in r["events"] if e.startswith("clock reset")] == \
                [e["t_ns"] for e in row["clock_events"]], row["station"]
    else:
        assert _events(lines) == _doc_events(doc)
    if monitor_args is None:
        return lines
    mon = runner.invoke(app, ["monitor", "--replay", str(path), "--replay-speed", "1e6", "--json-lines", *monitor_args])
    assert mon.exit_code == 0, mon.output
    records = [json.loads(line) for line in mon.stdout.splitlines()]
    streamed = {(r.get("station"), r["t_ns"]): r for r in lines}
    by_station = {}
    for key in streamed:
        by_station.setdefault(key[0], []).append(key[1])
    logged = {}
    for rec in records:
        if rec["clock_bias_s"] is None:
            continue
        station = rec["receiver"].split("/", 1)[1] if "/" in rec["receiver"] else None
        grid = by_station.get(station, [])
        slot = min(grid, key=lambda t: abs(t - rec["gps_ns"])) if grid else None  # a jittered tag: its grid slot
        if slot is None or abs(slot - rec["gps_ns"]) > 0.05 * _interval_ns(grid):
            # a clock with one epoch (no grid, nothing to difference): logged untested
            assert (rec["state"], rec["alarm"], rec["events"]) == ("unavailable", False, []), rec["receiver"]
            continue
        logged[(station, slot)] = rec
    assert records and all(rec["receiver"] for rec in records)
    for key, rec in logged.items():
        verdict = streamed[key]
        assert (rec["state"], rec["alarm"], rec["events"]) == (verdict["state"], verdict["alarm"], verdict["events"]), key
    # every epoch the stream had something to say about is one the monitor logged (the others are the grid's gaps)
    assert all(key in logged for key, v in streamed.items() if v["alarm"] or v["events"])
    return lines


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n.startswith("rinex/") else n
                                  for n in sorted(REAL)])
def test_detect_file_detect_pipe_and_the_monitor_agree_on_a_real_recording(name, tmp_path):
    window, train_s, extra = REAL[name]
    common = ["--window", str(window), *(MODEL if train_s is None else ["--train", str(train_s)])]
    rate = extra[:2] if extra[:1] == ["--rate"] else []
    rest = extra[2:] if rate else extra
    # the monitor takes a recording's own interval (no --rate): with one epoch it leaves the epoch untested
    _check_paths(RX / name, [*common, *rate, *rest], [*common, *rest], tmp_path)


@pytest.mark.parametrize("name", sorted(SIMULATED))
def test_detect_file_detect_pipe_and_the_monitor_agree_on_a_simulated_recording(name, tmp_path):
    path = tmp_path / f"{name}.ubx"
    path.write_bytes(SIMULATED[name]())
    lines = _check_paths(path, ["--train", "300"], ["--train", "300"], tmp_path)
    doc = json.loads(runner.invoke(app, ["detect", str(path), "--json", "--train", "300"]).stdout)
    # what each recording is there for, on the one program
    if name == "millisecond-reset":
        assert len(doc["clock_events"]) == 2 and doc["state"] == "ok" and doc["alarms"] == []
    elif name == "step":
        assert doc["state"] == "alarm" and 600 <= (doc["alarms"][0]["t_ns"] - lines[0]["t_ns"]) / 1e9 <= 602
    elif name == "ramp":
        raised = [e for e in doc["alarm_events"] if e["kind"] == "raise"]
        assert raised and doc["n_alarm_epochs"] >= 150  # latched while the ramp lasts, not only while it starts
    elif name == "fix-loss":
        assert doc["n_no_fix"] == 40
    elif name == "out-of-order":  # put back in order: every epoch tested, none missing, said so
        assert doc["n_epochs"] == 900 and doc["n_skipped"] == 0 and doc["state"] == "ok"
        assert any("2 epoch(s) arrived after a later one" in w for w in doc["warnings"]), doc["warnings"]
    elif name == "late-epoch":  # too late: a gap on every path, said so
        assert doc["n_epochs"] == 900 and doc["n_skipped"] == 1
        assert any("1 epoch(s) arrived more than 2 epochs late" in w for w in doc["warnings"]), doc["warnings"]


def _interval_ns(grid: list[int]) -> int:
    return min(b - a for a, b in zip(grid, grid[1:])) if len(grid) > 1 else 10**18


def test_a_paused_pipe_gets_every_closed_epochs_verdict_without_waiting_for_more_bytes():
    # Live, the reorder buffer held the last two closed epochs until more bytes came: a receiver that paused
    # (or a slow one) was two epochs behind. They are released after REORDER_HOLD_S of wall time, as the
    # monitor releases them; only the epoch still open (its next epoch has not begun) waits.
    import threading
    import time

    data = (RX / "gpsd/ublox-zed-f9p_hpg1.11.log").read_bytes()
    half = data[:len(data) // 2]
    args = [sys.executable, "-m", "chronofuse.cli.main", "detect", "-", "--json-lines", *MODEL, "--window", "20"]
    env = {**os.environ, "COLUMNS": "88"}
    batch = subprocess.run(args, input=half, capture_output=True, env=env, timeout=120).stdout.splitlines()
    proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env)
    lines: list[bytes] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()
    proc.stdin.write(half)
    proc.stdin.flush()
    deadline = time.monotonic() + 60
    while len(lines) < len(batch) - 1 and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(1.0)  # nothing more may come before the stream ends
    paused = len(lines)
    proc.stdin.close()
    proc.wait(timeout=60)
    reader.join(timeout=10)
    assert paused == len(batch) - 1
    assert [line.rstrip(b"\n") for line in lines] == batch
