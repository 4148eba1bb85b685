"""``chronofuse position --obs`` on real files, and ``inspect`` on Hatanaka files."""

from __future__ import annotations

import json

import numpy as np
import pytest
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


def _kms3(real_data):
    folder = real_data / "rinex" / "rinex4"
    return ["position", "--obs", str(folder / "KMS300DNK_R_20221591000_01H_30S_MO.crx.gz"),
            "--nav", str(folder / "KMS300DNK_R_20221591000_01H_MN.rnx.gz"), "--systems", "gps"]


def _one_error_line(result) -> str:
    assert result.exit_code == 2, result.output
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, lines
    return lines[0]


def test_a_navigation_file_of_another_day_is_an_error_naming_it_and_writes_nothing(igs_stations, tmp_path):
    bor1, nya1 = igs_stations["BOR1"], igs_stations["NYA1"]
    gn = next(p for p in nya1.nav_paths if "_GN" in p.name)
    out = tmp_path / "out"
    result = runner.invoke(app, ["position", "--obs", str(bor1.obs_path), "--nav", str(gn), "--systems", "gps",
                                 "--end", "600", "--out", str(out)])
    line = _one_error_line(result)
    assert "no ephemeris covers the observation epochs" in line and gn.name in line
    assert not (out / "positions.csv").exists()


def test_a_run_without_any_fix_is_an_error_with_its_reason_not_a_success(real_data, tmp_path):
    out = tmp_path / "out"
    # a 10 deg elevation mask is met; 89 deg leaves no satellite
    result = runner.invoke(app, _kms3(real_data) + ["--elevation-mask-deg", "89", "--out", str(out), "--json"])
    line = _one_error_line(result)
    assert "no epoch gives a fix" in line and "usable satellite" in line and "gps needs 4" in line
    assert not (out / "positions.csv").exists() and result.stdout == ""


@pytest.mark.parametrize("extra, named", [
    (["--end", "nan"], "--end == nan"), (["--start", "nan"], "--start == nan"), (["--start", "inf"], "--start == inf"),
    (["--start", "-100"], "--start == -100"), (["--start", "99999"], "--start == 99999 s to the file's end"),
    (["--ionosphere", "nequick"], "klobuchar, none"), (["--troposphere", "hopfield"], "saastamoinen, none"),
    (["--position", "nan,0,0"], "--position"), (["--position", "inf,1,1"], "--position"),
    (["--position", "0,0,0"], "km from the WGS 84 ellipsoid"), (["--position", "1,2,3"], "km from the WGS 84"),
    (["--systems", "gps+gps"], "gps twice"), (["--systems", "gps+GPS"], "gps twice"),
    (["--ins", "tactical"], "--ins"), (["--smooth"], "--smooth"), (["--trials", "3"], "--trials"),
])
def test_bad_or_idle_options_are_one_line_errors_naming_the_option(real_data, extra, named):
    args = _kms3(real_data)
    if extra[0] == "--systems":
        args = args[:-2]
    line = _one_error_line(runner.invoke(app, args + extra))
    assert named in line and "None" not in line


def test_the_options_of_real_files_are_refused_for_a_simulated_drive():
    line = _one_error_line(runner.invoke(app, ["position", "--position", "1,2,3", "--duration", "10"]))
    assert "--position" in line and "--obs" in line


def test_a_directory_given_as_navigation_file_is_named_as_one(real_data, tmp_path):
    args = _kms3(real_data)
    args[args.index("--nav") + 1] = str(tmp_path)
    line = _one_error_line(runner.invoke(app, args))
    assert "--nav" in line and "is a directory" in line


def test_systems_in_capitals_are_read_and_echoed_in_lower_case(real_data):
    args = _kms3(real_data)[:-1] + ["GPS"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    assert "with gps (" in result.stdout and "GPS (" not in result.stdout.replace("\n", " ")


def test_a_reference_far_from_the_fixes_is_analysed_with_a_warning(real_data):
    from chronofuse.io.rinex_obs import read_any_observations

    approx = read_any_observations(real_data / "rinex" / "rinex4" / "KMS300DNK_R_20221591000_01H_30S_MO.crx.gz",
                                   systems=("G",)).header.approx_position_m
    near = ",".join(f"{v:.4f}" for v in approx)
    far = ",".join(f"{v:.4f}" for v in approx + np.array([0.0, 0.0, 5000.0]))
    ok = runner.invoke(app, _kms3(real_data) + ["--position", near, "--json"])
    assert ok.exit_code == 0 and json.loads(ok.stdout)["warnings"] == []
    warned = runner.invoke(app, _kms3(real_data) + ["--position", far, "--json"])
    assert warned.exit_code == 0, warned.output
    doc = json.loads(warned.stdout)
    assert len(doc["warnings"]) == 1 and "--position is 5.0 km from the mean fix" in doc["warnings"][0]
    assert "warning: --position" in warned.stderr and doc["statistics"]["horizontal95_m"] > 1000


def test_a_galileo_only_navigation_file_warns_that_no_ionosphere_is_removed(igs_stations):
    s = igs_stations["AJAC"]
    result = runner.invoke(app, _args(s, "gal") + ["--end", "300", "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert len(doc["warnings"]) == 1 and "no GPS Klobuchar coefficients" in doc["warnings"][0]
    assert "--ionosphere == 'klobuchar'" in doc["warnings"][0] and "GRAS00FRA" in doc["warnings"][0]
