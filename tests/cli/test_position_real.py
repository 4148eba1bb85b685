"""``chronofuse position --obs`` on real files, and ``inspect`` on Hatanaka files."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from chronofuse.cli.main import app

runner = CliRunner()


def _args(station, systems="gps+bds"):
    args = ["position", "--obs", str(station.obs_path), "--systems", systems]
    for p in station.nav_paths:
        args += ["--nav", str(p)]
    return args


def test_position_from_a_hatanaka_file_writes_the_csv_and_the_statistics(igs_stations, tmp_path):
    s = igs_stations["ESBC"]
    ref = ",".join(f"{v:.4f}" for v in s.reference_arp_m)
    out = tmp_path / "out"
    result = runner.invoke(app, _args(s) + ["--position", ref, "--end", "3599", "--json", "--out", str(out)])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["epochs"] == doc["fixes"] == 120 and doc["codes"] == {"G": "C1C", "C": "C2I"}
    assert 0.3 < doc["statistics"]["horizontal95_m"] < 3.0 and doc["statistics"]["cep50_m"] < doc["statistics"]["cep95_m"]
    table = pd.read_csv(out / "positions.csv")
    assert len(table) == 120 and {"x_m", "clock_m", "isb_C_m", "east_m", "n_used", "gdop"} <= set(table.columns)
    # the CSV's errors are the positions' errors against the reference given
    h = np.hypot(table["east_m"], table["north_m"])
    assert abs(np.percentile(h, 95) - doc["statistics"]["horizontal95_m"]) < 1e-3


def test_gps_plus_bds_with_a_gps_only_navigation_file_is_refused_in_one_line(igs_stations):
    s = igs_stations["BOR1"]
    result = runner.invoke(app, _args(s) + ["--end", "60"])
    assert result.exit_code == 2
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "no BDS ephemeris" in lines[0] and "BRDC00CNE" in lines[0]


def test_bad_options_are_refused_naming_them(igs_stations):
    s = igs_stations["BOR1"]
    for extra, word in ((["--position", "1,2"], "--position"), (["--start", "60", "--end", "0"], "--end"),
                        (["--systems", "gps+glonass"], "systems")):
        result = runner.invoke(app, [a for a in _args(s, "gps") if a != "gps+bds"] + extra)
        assert result.exit_code == 2 and word in result.output
    result = runner.invoke(app, ["position", "--obs", str(s.obs_path)])
    assert result.exit_code == 2 and "--nav" in result.output


def test_inspect_counts_the_epochs_of_a_hatanaka_file(igs_stations):
    result = runner.invoke(app, ["inspect", str(igs_stations["NYA1"].obs_path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["epochs"] == 2880 and doc["protocols"] == ["rinex-obs"] and doc["interval_s"] == 30.0
