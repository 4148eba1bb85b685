"""`chronofuse inspect`: the JSON document, the export table (CSV and Parquet) against the reader, and
one-line errors on bad input."""

from __future__ import annotations

import gzip
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import inspect as inspect_cli
from chronofuse.epochs import EXPORT_COLUMNS
from chronofuse.io.inspect import read_capture

from _helpers import receivers_dir  # noqa: E402

runner = CliRunner()
app = typer.Typer()
inspect_cli.register(app)


@app.callback()
def _root() -> None:
    """Local app holding only the command under test."""


M8T = receivers_dir() / "gpsd" / "u-blox-m8t-time.log"


def test_json_reports_counts_span_and_damage_of_a_timing_receiver_capture():
    result = runner.invoke(app, ["inspect", str(M8T), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["messages"]["TIM-TP"] == 152 and doc["messages"]["NAV-TIMELS"] == 151
    assert doc["protocols"] == ["ubx"]
    assert doc["leap_s"] == [18]
    assert doc["start_utc"] == "2021-02-23T18:04:29.000Z"
    assert doc["damage"]["truncated_frames"] == 1  # gpsd's capture ends inside a frame
    assert doc["gaps"]["count"] == 0


def test_bad_checksums_and_unknown_talkers_are_reported(tmp_path):
    good = b"$GPRMC,120000.00,A,4807.038,N,01131.000,E,0.0,0.0,010125,,,A*"
    check = 0
    for ch in good[1:-1]:
        check ^= ch
    line = good + f"{check:02X}\r\n".encode()
    bad = line.replace(b"*", b"*0").replace(b"\r\n", b"")[:-1] + b"\r\n"
    talker = b"$XXGGA,120001.00,,,,,0,00,,,M,,M,,*"
    check = 0
    for ch in talker[1:-1]:
        check ^= ch
    path = tmp_path / "rec.nmea"
    path.write_bytes(line + bad + talker + f"{check:02X}\r\n".encode())
    doc = json.loads(runner.invoke(app, ["inspect", str(path), "--json"]).stdout)
    assert doc["damage"]["nmea_bad_checksum"] + doc["damage"]["nmea_malformed"] == 1
    assert doc["unknown_talkers"] == {"XX": 1}
    assert doc["epochs"] == 1


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_export_has_exactly_the_columns_and_the_readers_values(tmp_path, suffix):
    out = tmp_path / f"epochs{suffix}"
    result = runner.invoke(app, ["inspect", str(M8T), "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(out) if suffix == ".csv" else pd.read_parquet(out)
    assert tuple(table.columns) == EXPORT_COLUMNS
    capture = read_capture(M8T)
    assert len(table) == capture.n_epochs
    np.testing.assert_allclose(table["qerr_s"], capture.rows["qerr_s"], equal_nan=True)
    assert table["time_utc"].iloc[0] == "2021-02-23T18:04:29.000Z"


def test_a_gzip_recording_reads_like_the_plain_one(tmp_path):
    packed = tmp_path / "m8t.log.gz"
    packed.write_bytes(gzip.compress(M8T.read_bytes()))
    plain = json.loads(runner.invoke(app, ["inspect", str(M8T), "--json"]).stdout)
    zipped = json.loads(runner.invoke(app, ["inspect", str(packed), "--json"]).stdout)
    assert {k: v for k, v in zipped.items() if k != "file"} == {k: v for k, v in plain.items() if k != "file"}


def test_a_missing_file_is_one_line_on_stderr_and_exit_code_2(tmp_path):
    result = runner.invoke(app, ["inspect", str(tmp_path / "none.ubx")])
    assert result.exit_code == 2
    assert "none.ubx" in result.output and len(result.output.strip().splitlines()) == 1


def test_an_export_name_without_a_table_suffix_is_refused(tmp_path):
    result = runner.invoke(app, ["inspect", str(M8T), "--out", str(tmp_path / "out.xlsx")])
    assert result.exit_code == 2
    assert "--out" in result.output
