"""`chronofuse monitor`: records acknowledged on stdout survive a SIGKILL mid-stream (rows counted
against the lines printed before the kill), the replay path, the session report, one-line errors."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import typer
from typer.testing import CliRunner

from chronofuse.cli import monitor as monitor_cli
from chronofuse.io.inspect import read_capture

from _helpers import receivers_dir  # noqa: E402

runner = CliRunner()
app = typer.Typer()
monitor_cli.register(app)
REPO = Path(__file__).resolve().parents[2]
F9P = receivers_dir() / "gpsd" / "ublox-zed-f9p_hpg1.11.log"  # 655 s of NAV-CLOCK at 1 Hz, NMEA mixed in
M8T = receivers_dir() / "gpsd" / "u-blox-m8t-time.log"


@app.callback()
def _root() -> None:
    """Local app holding only the command under test."""


def test_no_acknowledged_record_is_lost_when_the_monitor_is_killed_mid_stream(tmp_path):
    db = tmp_path / "log.db"
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    cmd = [sys.executable, "-m", "chronofuse.cli.main", "monitor", "--replay", str(F9P), "--replay", str(M8T),
           "--replay-speed", "20", "--db", str(db), "--json-lines"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env, cwd=tmp_path)
    printed = []
    deadline = time.monotonic() + 120
    while len(printed) < 120 and time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        printed.append(json.loads(line))
    proc.send_signal(signal.SIGKILL)  # mid-stream: the replay has ~650 epochs to go
    proc.wait()
    assert len(printed) >= 120
    rows = set(sqlite3.connect(db).execute("SELECT receiver, gps_ns FROM epochs").fetchall())
    assert len(rows) >= len(printed)
    assert all((r["receiver"], r["gps_ns"]) in rows for r in printed)


def test_a_replay_logs_every_epoch_of_the_recording_and_the_report_plots_it(tmp_path):
    db = tmp_path / "log.db"
    result = runner.invoke(app, ["monitor", "--replay", str(M8T), "--replay", str(F9P), "--replay-speed", "1000", "--db",
                                 str(db), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    # every epoch the file reader finds, the F9P's NMEA-only epoch included (NMEA and UBX merged live as in files)
    expected = read_capture(M8T).n_epochs + read_capture(F9P).n_epochs
    assert expected == 151 + 656
    assert doc["acknowledged"] == expected == sqlite3.connect(db).execute("SELECT COUNT(*) FROM epochs").fetchone()[0]
    out = tmp_path / "report"
    result = runner.invoke(app, ["monitor", "--report", str(db), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    by_name = {r["receiver"]: r for r in summary["receivers"]}
    # the two TIM-TP whose pulse has no navigation epoch (before the first, after the last) are no epochs
    assert by_name["u-blox-m8t-time.log"]["epochs"] == 151
    # no NAV-CLOCK: its integrity is never tested, so none of its 151 qualified epochs is usable
    assert by_name["u-blox-m8t-time.log"]["usable"] == 0
    assert by_name["ublox-zed-f9p_hpg1.11.log"]["clock_bias_epochs"] == 655
    assert (out / "ublox-zed-f9p_hpg1.11.log_clock_bias.png").stat().st_size > 0
    assert (out / "ublox-zed-f9p_hpg1.11.log_adev.png").stat().st_size > 0
    assert json.loads((out / "summary.json").read_text()) == summary


def test_json_and_json_lines_together_are_refused_in_one_line():
    result = runner.invoke(app, ["monitor", "--replay", str(M8T), "--json", "--json-lines"])
    assert result.exit_code == 2
    assert len(result.output.strip().splitlines()) == 1


def test_a_report_of_a_file_that_is_no_log_names_it(tmp_path):
    bogus = tmp_path / "x.db"
    bogus.write_text("not sqlite")
    result = runner.invoke(app, ["monitor", "--report", str(bogus), "--out", str(tmp_path / "o")])
    assert result.exit_code == 2
    assert "x.db" in result.output
