"""A receiver's name: a replayed recording is named by its file, whatever the order of the options (so the
log's one-row-per-receiver-and-epoch key holds across runs); the table keeps distinct names distinct."""

from __future__ import annotations

import os
import sqlite3
import subprocess
import sys

import numpy as np

from _real_parts import REPO

from .conftest import ubx_stream

ENV = {**os.environ, "PYTHONPATH": str(REPO / "src")}


def _monitor(*args, cwd):
    out = subprocess.run([sys.executable, "-m", "chronofuse", "monitor", *args, "--replay-speed", "50", "--no-table",
                          "--quiet"], cwd=cwd, capture_output=True, text=True, timeout=120, env=ENV)
    assert out.returncode == 0, out.stderr
    return out


def test_the_same_recordings_replayed_in_another_order_into_one_log_give_no_duplicate_rows(tmp_path):
    a, b = tmp_path / "a.ubx", tmp_path / "b.ubx"
    a.write_bytes(ubx_stream(np.zeros(20)))
    b.write_bytes(ubx_stream(np.zeros(25)))
    db = tmp_path / "log.db"
    _monitor("--replay", str(a), "--replay", str(b), "--db", str(db), cwd=tmp_path)
    _monitor("--replay", str(b), "--replay", str(a), "--db", str(db), cwd=tmp_path)  # was a#1, b#0: 90 rows
    con = sqlite3.connect(db)
    rows = dict(con.execute("SELECT receiver, COUNT(*) FROM epochs GROUP BY receiver").fetchall())
    assert rows == {"a.ubx": 20, "b.ubx": 25}


def test_one_file_given_twice_in_one_run_is_two_receivers(tmp_path):
    a = tmp_path / "a.ubx"
    a.write_bytes(ubx_stream(np.zeros(20)))
    db = tmp_path / "log.db"
    _monitor("--replay", str(a), "--replay", str(a), "--db", str(db), cwd=tmp_path)
    con = sqlite3.connect(db)
    rows = dict(con.execute("SELECT receiver, COUNT(*) FROM epochs GROUP BY receiver").fetchall())
    assert rows == {"a.ubx#0": 20, "a.ubx#1": 20}


def test_the_table_keeps_names_that_differ_in_their_middle_distinct_and_the_reasons_readable_at_60(tmp_path):
    from rich.console import Console

    from chronofuse.io.sources import FileSource
    from chronofuse.monitor.decisions import MonitorSettings
    from chronofuse.monitor.engine import Monitor
    from chronofuse.monitor.table import receiver_table

    sources = []
    for serial in ("SN1111", "SN2222"):  # udev by-id names: only the serial number tells them apart
        name = f"usb-u-blox_AG_GNSS_receiver_{serial}-if00-port0"
        path = tmp_path / f"{name}.ubx"
        path.write_bytes(ubx_stream(np.zeros(12)))
        sources.append(FileSource(path, name=name))
    mon = Monitor(sources, MonitorSettings())
    mon.run(duration_s=20)
    for width in (60, 80, 100):
        console = Console(record=True, width=width, force_terminal=False)
        console.print(receiver_table(mon, width=width))
        text = console.export_text()
        assert max(len(line) for line in text.splitlines()) <= width, text
        assert "SN1111" in text and "SN2222" in text, text  # were both `usb-u-b…0-port0`
        if width == 60:
            assert "integrity not tested" in text, text  # the reasons had 4 columns
