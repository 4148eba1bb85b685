"""`chronofuse monitor` as a program: JSON lines to a file and to stdout while the live table is drawn on a
pseudo-terminal, bad sources named in one line with exit 2, the retry policy visible, a replay logged
twice into one database without duplicates, the log's exports equal to its rows, an outage counted once
with its duration however many reconnections it took."""

from __future__ import annotations

import fcntl
import json
import os
import pty
import socket
import sqlite3
import struct
import subprocess
import sys
import termios
import threading
import time

import numpy as np
import pandas as pd
import pytest

from _helpers import receivers_dir
from _real_parts import REPO, MonitorProcess

M8T = receivers_dir() / "gpsd" / "u-blox-m8t-time.log"  # 151 epochs
ENV = {**os.environ, "PYTHONPATH": str(REPO / "src")}


def _chronofuse(*args, timeout_s: float = 60.0, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "chronofuse.cli.main", *args], capture_output=True, text=True,
                          env=ENV, timeout=timeout_s, **kw)


def _log(*args):
    """``chronofuse log ...`` in this process (the query commands; the monitor itself runs as a program)."""
    from typer.testing import CliRunner

    from chronofuse.cli.main import build_app

    result = CliRunner().invoke(build_app(("log", "monitor")), list(args))
    assert result.exit_code == 0, result.output
    return result


def test_json_lines_reach_a_file_and_stdout_while_the_live_table_is_drawn_on_a_terminal(tmp_path):
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 100, 0, 0))  # a 100-column terminal
    screen = bytearray()

    def read_screen():
        while True:
            try:
                chunk = os.read(master, 65536)
            except OSError:
                return
            if not chunk:
                return
            screen.extend(chunk)

    reader = threading.Thread(target=read_screen, daemon=True)
    reader.start()
    lines_file = tmp_path / "epochs.jsonl"
    env = {k: v for k, v in ENV.items() if k not in ("COLUMNS", "LINES")}
    with open(tmp_path / "stdout.jsonl", "wb") as stdout:
        proc = subprocess.run([sys.executable, "-m", "chronofuse.cli.main", "monitor", "--replay", str(M8T), "--replay-speed",
                               "60", "--json-lines", "--json-lines-file", str(lines_file)], stdout=stdout, stderr=slave,
                              stdin=slave, env={**env, "TERM": "xterm-256color"}, timeout=120)
    os.close(slave)
    reader.join(5)
    os.close(master)
    assert proc.returncode == 0
    from_file = [json.loads(line) for line in lines_file.read_text().splitlines()]
    from_stdout = [json.loads(line) for line in (tmp_path / "stdout.jsonl").read_text().splitlines()]
    assert len(from_file) == len(from_stdout) == 151
    assert from_file == from_stdout
    text = screen.decode(errors="replace")
    assert "chronofuse monitor: 1 receiver(s)" in text  # the table was drawn on the terminal
    assert "u-blox-m8t-time.log" in text  # the whole name, not three letters
    assert "link_up" in text and "ended" in text  # event lines above it


@pytest.mark.parametrize("spec", ["serial:/dev/ttyNOPE", "tcp:127.0.0.1:1", "gpsd:127.0.0.1:1", "/no/such/capture.ubx"])
def test_a_bad_source_is_one_line_naming_it_and_exit_2(spec):
    started = time.monotonic()
    done = _chronofuse("monitor", spec, timeout_s=30)
    assert done.returncode == 2, done.stderr
    errors = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, done.stderr
    name = spec.split(":", 1)[1] if spec.startswith(("serial:", "tcp:")) else spec
    assert name.replace("127.0.0.1:1", "127.0.0.1") in errors[0] or "gpsd:127.0.0.1:1" in errors[0], errors
    assert time.monotonic() - started < 40


def test_a_source_that_comes_up_within_the_connect_timeout_is_used_and_the_retries_are_visible(tmp_path):
    probe = socket.create_server(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()  # nothing listens there for now
    data = M8T.read_bytes()

    def serve_later():
        time.sleep(0.5)
        server = socket.create_server(("127.0.0.1", port))
        conn, _ = server.accept()
        conn.sendall(data)
        conn.close()
        server.close()

    proc = MonitorProcess([f"tcp:127.0.0.1:{port}", "--connect-timeout-s", "20", "--json-lines", "--no-table"], tmp_path)
    proc.wait_for_stderr(f"127.0.0.1:{port} link_down: cannot open", 30)  # the first failure is told, once
    threading.Thread(target=serve_later, daemon=True).start()
    proc.wait_for_stderr(f"127.0.0.1:{port} link_up: back after", 30)
    deadline = time.monotonic() + 20
    while len(proc.stdout_path.read_text().splitlines()) < 140 and time.monotonic() < deadline:
        time.sleep(0.2)
    assert proc.stop() in (0, -2, 130)
    assert len(proc.stdout_path.read_text().splitlines()) >= 140  # the capture's epochs, once the server came
    assert proc.stderr().count("link_down: cannot open") == 1


def test_without_a_retry_window_a_refused_source_gives_up_and_says_how_long_it_tried():
    probe = socket.create_server(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    started = time.monotonic()
    done = _chronofuse("monitor", f"tcp:127.0.0.1:{port}", "--connect-timeout-s", "1.5", timeout_s=30)
    assert done.returncode == 2
    assert 1.4 < time.monotonic() - started < 40  # the program's start-up included (seconds on a loaded machine)
    error = [line for line in done.stderr.splitlines() if line.startswith("error:")]
    assert len(error) == 1 and f"127.0.0.1:{port}" in error[0] and "retried for" in error[0], done.stderr


def test_a_replay_logged_twice_into_one_database_has_no_duplicates_and_exports_agree_row_by_row(tmp_path):
    db = tmp_path / "log.db"
    for _ in range(2):
        done = _chronofuse("monitor", "--replay", str(M8T), "--replay-speed", "1000", "--db", str(db), "--no-table")
        assert done.returncode == 0, done.stderr
    con = sqlite3.connect(db)
    assert con.execute("SELECT COUNT(*) FROM epochs").fetchone()[0] == 151
    assert con.execute("SELECT COUNT(DISTINCT receiver || gps_ns) FROM epochs").fetchone()[0] == 151
    rows = pd.read_sql_query("SELECT * FROM epochs ORDER BY receiver, gps_ns", con).drop(columns=["id"])
    con.close()
    for suffix in ("csv", "parquet"):
        out = tmp_path / f"epochs.{suffix}"
        _log("log", "epochs", str(db), "--out", str(out))
        exported = pd.read_csv(out, keep_default_na=True) if suffix == "csv" else pd.read_parquet(out)
        assert list(exported.columns) == list(rows.columns)
        assert len(exported) == len(rows) == 151
        for col in rows.columns:
            ours, theirs = rows[col].to_numpy(), exported[col].to_numpy()
            if rows[col].dtype.kind in "fi" or col in ("usable", "alarm", "dissent", "jump", "time_valid"):
                np.testing.assert_array_equal(pd.to_numeric(pd.Series(theirs)).astype(float).to_numpy(),
                                              pd.to_numeric(pd.Series(ours)).astype(float).to_numpy(), err_msg=col)
            else:
                assert [("" if v is None or v != v else str(v)) for v in ours] == \
                       [("" if v is None or v != v else str(v)) for v in theirs], col
    # a time range: the first 10 s of the capture
    first = rows["utc"].iloc[0][:19]
    done = _log("log", "epochs", str(db), "--from", first, "--to", str(np.datetime64(first) + np.timedelta64(10, "s")),
                "--json")
    assert json.loads(done.stdout)["rows"] == 10


def test_an_outage_with_many_reconnection_attempts_is_counted_once_with_its_duration(tmp_path):
    data = M8T.read_bytes()
    half = len(data) // 2
    probe = socket.create_server(("127.0.0.1", 0))
    port = probe.getsockname()[1]
    probe.close()
    down_s = 2.5

    def serve():
        for part in (data[:half], data[half:]):
            server = socket.create_server(("127.0.0.1", port))
            conn, _ = server.accept()
            conn.sendall(part)
            time.sleep(0.5)
            conn.close()
            server.close()  # refused from now on: every retry fails until the server is back
            time.sleep(down_s)

    threading.Thread(target=serve, daemon=True).start()
    db = tmp_path / "log.db"
    proc = MonitorProcess([f"tcp:127.0.0.1:{port}", "--db", str(db), "--no-table", "--connect-timeout-s", "5"], tmp_path)
    proc.wait_for_stderr(r"link_up: back after (\d+) failed", 45)
    time.sleep(1.0)
    proc.stop()
    table = json.loads(_log("log", "outages", str(db), "--json").stdout)["table"]
    assert len(table) >= 1
    first = table[0]
    assert first["attempts"] >= 3  # backoff 0.1, 0.2, 0.4, 0.8 s ... within the 2.5 s it was down
    assert down_s - 0.5 < first["duration_s"] < down_s + 3.0
    assert "closed by the other end" in first["reason"]
    con = sqlite3.connect(db)
    downs = con.execute("SELECT COUNT(*) FROM events WHERE kind = 'link_down'").fetchone()[0]
    assert downs == len(table)  # one event per outage, not one per failed attempt
    report = _log("monitor", "--report", str(db), "--out", str(tmp_path / "report"), "--json")
    summary = json.loads(report.stdout)["receivers"][0]
    assert len(summary["outages"]) == len(table)
    assert summary["outages"][0]["duration_s"] == pytest.approx(first["duration_s"])
