"""Bad input to ``chronofuse monitor`` and ``chronofuse log`` is one line naming the option or the file and
exit 2, never a traceback, a hang, a silent exit 0 or exit 70; a closed pipe on stdout ends the run quietly;
a corrupt frame is dropped with an event while the other receivers go on."""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import subprocess
import sys

import numpy as np
import pytest

from _real_parts import REPO
from chronofuse.monitor import logquery
from chronofuse.monitor.log import EpochLog

from .conftest import ubx_stream

ENV = {**os.environ, "PYTHONPATH": str(REPO / "src"), "COLUMNS": "200"}


def _cli(*args, cwd, timeout=60, **kw):
    return subprocess.run([sys.executable, "-m", "chronofuse", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=ENV, **kw)


def _refused(out, *words):
    assert out.returncode == 2, (out.returncode, out.stderr)
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), out.stderr
    for word in words:
        assert word in lines[0], lines[0]


@pytest.fixture
def recording(tmp_path):
    path = tmp_path / "rx.ubx"
    path.write_bytes(ubx_stream(np.zeros(30)))
    return path


@pytest.mark.parametrize("args, words", [
    (["serial:/dev/ttyNOPE@-5"], ["baud rate -5"]),  # was a thread's traceback, then a hang
    (["tcp:127.0.0.1:70000"], ["port 70000"]),
    (["--replay", "{rec}", "--webhook", "notaurl"], ["--webhook", "notaurl"]),
    (["--replay", "{rec}", "--webhook", "ftp://x/y"], ["--webhook"]),
    (["--replay", "{rec}", "--duration", "-1"], ["--duration"]),
    (["--replay", "{rec}", "--jump-ns", "-5"], ["--jump-ns"]),
    (["--replay", "{rec}", "--db", "/nonexist/x.db"], ["--db", "/nonexist"]),
])
def test_a_bad_source_or_option_is_one_line_and_exit_2(tmp_path, recording, args, words):
    out = _cli("monitor", *[a.replace("{rec}", str(recording)) for a in args], "--no-table", cwd=tmp_path, timeout=30)
    _refused(out, *words)
    assert not os.path.exists("/nonexist")  # the missing folder is not made


@pytest.mark.parametrize("content", [b"", bytes(range(256)) * 8])
def test_a_positional_file_that_is_empty_or_garbage_is_refused_as_replay_refuses_it(tmp_path, content):
    path = tmp_path / "bad.ubx"
    path.write_bytes(content)
    for args in ([str(path)], ["--replay", str(path)]):
        _refused(_cli("monitor", *args, "--no-table", cwd=tmp_path), str(path))  # the positional was exit 0


def test_an_http_address_in_use_or_not_on_this_host_is_refused_naming_the_option(tmp_path, recording):
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen()
    try:
        port = busy.getsockname()[1]
        _refused(_cli("monitor", "--replay", str(recording), "--http", f"127.0.0.1:{port}", "--no-table",
                      cwd=tmp_path), "--http", "cannot listen")
    finally:
        busy.close()
    _refused(_cli("monitor", "--replay", str(recording), "--http", "192.0.2.1:0", "--no-table", cwd=tmp_path),
             "--http", "cannot listen")


def test_json_lines_into_a_pipe_closed_early_ends_quietly(tmp_path, recording):
    monitor = subprocess.Popen([sys.executable, "-m", "chronofuse", "monitor", "--replay", str(recording),
                                "--replay-speed", "50", "--json-lines", "--no-table"], cwd=tmp_path, env=ENV,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = monitor.stdout.readline()  # `| head -1`
    monitor.stdout.close()
    err = monitor.stderr.read().decode()
    assert monitor.wait(60) == 0, err  # was exit 70 with BrokenPipeError
    assert json.loads(first)["receiver"] == "rx.ubx"
    assert "Error" not in err and "error" not in err, err


def test_a_frame_with_an_impossible_week_is_dropped_and_the_other_receivers_go_on(tmp_path, recording):
    huge = tmp_path / "huge.ubx"
    huge.write_bytes(ubx_stream(np.zeros(20), week=32000))
    out = _cli("monitor", "--replay", str(huge), "--replay", str(recording), "--replay-speed", "50", "--no-table",
               "--json", cwd=tmp_path)
    assert out.returncode == 0, out.stderr  # was exit 70: an int64 overflow ended every receiver
    counts = {r["receiver"]: r["epochs"] for r in json.loads(out.stdout)["receivers"]}
    assert counts == {"huge.ubx": 0, "rx.ubx": 30}
    assert "huge.ubx frame_dropped:" in out.stderr
    assert "GPS week 32000" in out.stderr or "UTC year" in out.stderr


def _log_with(tmp_path, rows, events=()):
    log = EpochLog(tmp_path / "log.db")
    log.append(rows, events)
    log.close()
    return tmp_path / "log.db"


def _row(name, k, **kw):
    gps_ns = (1_391_040_000 + k) * 10**9
    return {"receiver": name, "gps_ns": gps_ns, "utc": f"t{k}", "fix_mode": 3, "time_valid": True, "n_sats": 9,
            "leap_s": 18, "leap_pending": 0, "usable": True, "alarm": False, "dissent": False, "jump": False,
            "state": "ok", "reasons": [], **kw}


@pytest.mark.parametrize("args, words", [
    (["epochs", "{db}", "--station", "nosuch"], ["--station 'nosuch'", "no such receiver", "it holds: a, b"]),
    (["epochs", "{db}", "--from", "2024-02-06", "--to", "2024-02-05"], ["--from is not before --to"]),
    (["availability", "{db}", "--bin", "0"], ["--bin == 0"]),  # named interval_s before
    (["outages", "{db}", "--station", "nosuch"], ["--station"]),
])
def test_a_bad_log_query_is_one_line_and_exit_2(tmp_path, args, words):
    db = _log_with(tmp_path, [_row("a", 0), _row("b", 0)])
    out = _cli("log", *[a.replace("{db}", str(db)) for a in args], cwd=tmp_path)
    _refused(out, *words)
    assert "interval_s" not in out.stderr and "bin_s" not in out.stderr


def test_the_summary_counts_the_latched_alarm_as_log_alarms_does_and_outages_are_iso_utc(tmp_path):
    from chronofuse.monitor.events import MonitorEvent

    # 10 epochs latched in alarm, of which 3 over the threshold
    rows = [_row("a", k, state="alarm" if 5 <= k < 15 else "ok", alarm=k in (5, 6, 7), usable=not 5 <= k < 15)
            for k in range(30)]
    events = [MonitorEvent("a", "link_down", 1_700_000_000.25, "closed"),
              MonitorEvent("a", "link_up", 1_700_000_002.75, "back after 3 failed attempt(s)", duration_s=2.5)]
    db = _log_with(tmp_path, rows, events)
    summary = json.loads(_cli("log", "summary", str(db), "--json", cwd=tmp_path).stdout)["table"][0]
    alarms = json.loads(_cli("log", "alarms", str(db), "--json", cwd=tmp_path).stdout)["table"]
    assert summary["alarm_epochs_latched"] == sum(run["epochs"] for run in alarms) == 10  # was 3 against 10
    assert summary["detections"] == 3
    text = _cli("log", "outages", str(db), cwd=tmp_path).stdout
    assert "2023-11-14T22:13:20.250Z" in text and "2023-11-14T22:13:22.750Z" in text and "e+09" not in text


def test_availability_does_not_count_the_time_before_a_receivers_first_epoch(tmp_path):
    # the first epoch 100 s into a 3600 s bin, every epoch usable: fully available from there
    start = (1_391_040_000 // 3600) * 3600 + 100
    rows = [_row("a", 0, gps_ns=(start + k) * 10**9) for k in range(200)]
    db = _log_with(tmp_path, rows)
    frame = logquery.availability(db, 3600.0)
    assert frame["expected"].iloc[0] == 3500.0  # was 3600: the 100 s before it counted as unavailable
    assert frame["usable"].iloc[0] == 200
    con = sqlite3.connect(db)
    assert con.execute("SELECT COUNT(*) FROM epochs").fetchone()[0] == 200
