"""`chronofuse position`: JSON per solution, real broadcast orbits, and one-line errors for bad input."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app

runner = CliRunner()


def _run(*args):
    return runner.invoke(app, ["position", *args])


def test_position_prints_cep_and_vertical_per_solution_as_json(tmp_path):
    result = _run("--environment", "tunnel", "--systems", "gps", "--ins", "tactical", "--smooth", "--duration", "420",
                  "--trials", "2", "--imu-rate", "20", "--json", "--out", str(tmp_path / "out"))
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert set(doc["solutions"]) == {"gnss", "gnss+ins", "gnss+ins+rts"}
    for sol in doc["solutions"].values():
        assert {"cep50_m", "cep95_m", "vertical95_m"} <= set(sol)
        assert 0 < sol["cep50_m"] <= sol["cep95_m"]
    assert doc["outage_s"] >= 60 and doc["gdop_mean"] > 1
    assert (tmp_path / "out" / "outages.png").is_file() and (tmp_path / "out" / "trajectory.png").is_file()


def test_real_broadcast_orbits_drive_the_gps_satellites(real_data):
    nav = real_data / "receivers" / "rinex" / "rtklib" / "07590920.05n"
    result = _run("--environment", "open-sky", "--systems", "gps", "--ins", "none", "--duration", "60", "--trials", "1",
                  "--imu-rate", "10", "--nav", str(nav), "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["satellites"] == "broadcast" and doc["solutions"]["gnss"]["cep95_m"] < 10


@pytest.mark.parametrize("args, named", [
    (["--imu-rate", "5"], "--imu-rate"),
    (["--speed", "300"], "--speed"),
    (["--environment", "desert"], "--environment"),
    (["--ins", "navigation-grade"], "ins"),
])
def test_bad_options_are_one_line_errors_naming_the_option(args, named):
    result = _run("--duration", "20", "--trials", "1", *args)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and named in lines[0]


def test_a_gps_navigation_file_is_refused_for_gps_plus_bds_naming_the_file(real_data):
    nav = real_data / "receivers" / "rinex" / "rtklib" / "07590920.05n"
    result = _run("--systems", "gps+bds", "--nav", str(nav), "--duration", "20", "--trials", "1", "--imu-rate", "10")
    assert result.exit_code == 2
    line = result.stderr.strip()
    assert "07590920.05n" in line and "BDS" in line and len(line.splitlines()) == 1
