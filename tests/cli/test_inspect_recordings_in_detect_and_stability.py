"""Any recording `chronofuse inspect` reads goes straight into `chronofuse stability` and `chronofuse
detect`: its clock bias against an independent computation (allantools on the NAV-CLOCK values decoded by
hand from the interface description; the detector on the same values written as a CSV), and a one-line
refusal for a recording that carries no clock bias."""

from __future__ import annotations

import gzip
import json
import sys
from pathlib import Path

import allantools
import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import build_app

from _helpers import receivers_dir

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "io"))
from ubx_by_hand import nav_clock_by_hand  # noqa: E402

runner = CliRunner()
app = build_app(("stability", "detect", "inspect"))
F9P = receivers_dir() / "gpsd" / "ublox-zed-f9p_hpg1.11.log.gz"  # 655 NAV-CLOCK solutions, NMEA mixed in


def _json(*args):
    result = runner.invoke(app, [*map(str, args)])
    assert result.exit_code in (0, 1), result.output
    return json.loads(result.stdout)


def test_stability_of_a_ubx_capture_is_allantools_adev_of_its_nav_clock_bias():
    _, bias, _ = nav_clock_by_hand(gzip.decompress(F9P.read_bytes()))
    doc = _json("stability", F9P, "--dev", "adev,oadev", "--json")
    assert doc["n"] == bias.size == 655 and doc["rate"] == 1.0 and doc["gaps"] == 0
    for ours, theirs in (("adev", allantools.adev), ("oadev", allantools.oadev)):
        taus = np.asarray(doc["deviations"][ours]["tau"])
        tau_ref, dev_ref, _, _ = theirs(bias, rate=1.0, data_type="phase", taus=taus)
        np.testing.assert_array_equal(tau_ref, taus)
        np.testing.assert_allclose(doc["deviations"][ours]["dev"], dev_ref, rtol=1e-9)


def test_detect_on_a_capture_is_detect_on_its_clock_bias_written_as_a_table(tmp_path):
    itow, bias, _ = nav_clock_by_hand(gzip.decompress(F9P.read_bytes()))
    table = tmp_path / "bias.csv"
    table.write_text("t_ms,clock_bias_s\n" + "".join(f"{t},{float(b)!r}\n" for t, b in zip(itow, bias)))
    ours = _json("detect", F9P, "--train", 300, "--json")
    ref = _json("detect", table, "--train", 300, "--json")
    assert ours["n_epochs"] == ref["n_epochs"] == 655 and ours["interval_s"] == 1.0
    for key in ("mode", "state", "n_tested", "n_training", "threshold", "n_alarms"):
        assert ours[key] == ref[key], key
    assert [a["t_ns"] for a in ours["alarms"]] == [a["t_ns"] for a in ref["alarms"]]
    np.testing.assert_allclose([a["statistic"] for a in ours["alarms"]], [a["statistic"] for a in ref["alarms"]],
                               rtol=1e-9)


@pytest.mark.parametrize("command", ["stability", "detect"])
def test_an_nmea_recording_is_refused_in_one_line_saying_nmea_has_no_clock_bias(command):
    path = receivers_dir() / "gpsd" / "ac12.log"
    extra = ["--train", "60"] if command == "detect" else []
    result = runner.invoke(app, [command, str(path), *extra, "--json"])
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and str(path) in lines[0], result.stderr
    assert "NMEA 0183 carries no receiver clock bias" in lines[0] and "NAV-CLOCK" in lines[0]
    assert result.stdout == ""


def test_stability_of_a_gzipped_rinex_clock_product_is_allantools_on_its_first_stations_ar_lines():
    path = receivers_dir() / "rinex" / "rtklib" / "igs15904.clk.gz"
    lines = gzip.decompress(path.read_bytes()).decode("ascii").splitlines()
    body = lines[next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1:]
    first = next(line.split()[1] for line in body if line.startswith("AR "))
    # RINEX clock 2.00: AR, station, y m d h min s, number of values, bias (s)
    bias = np.array([float(line.split()[9]) for line in body if line.startswith("AR ") and line.split()[1] == first])
    doc = _json("stability", path, "--dev", "oadev", "--json")
    assert doc["n"] == bias.size == 12 and doc["rate"] == pytest.approx(1 / 300)
    assert any(first in note and "176 stations" in note for note in doc["warnings"])
    taus = np.asarray(doc["deviations"]["oadev"]["tau"])
    _, dev_ref, _, _ = allantools.oadev(bias, rate=1 / 300, data_type="phase", taus=taus)
    np.testing.assert_allclose(doc["deviations"]["oadev"]["dev"], dev_ref, rtol=1e-9)


def test_stability_with_station_analyses_that_station_of_a_clock_product_and_refuses_one_it_lacks():
    path = receivers_dir() / "rinex" / "rtklib" / "igs15904.clk.gz"
    lines = gzip.decompress(path.read_bytes()).decode("ascii").splitlines()
    body = lines[next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1:]
    stations = list(dict.fromkeys(line.split()[1] for line in body if line.startswith("AR ")))
    last = stations[-1]  # not the default first one
    bias = np.array([float(line.split()[9]) for line in body if line.startswith("AR ") and line.split()[1] == last])
    doc = _json("stability", path, "--station", last, "--dev", "oadev", "--json")
    assert doc["n"] == bias.size and not any("stations: the first" in note for note in doc["warnings"])
    taus = np.asarray(doc["deviations"]["oadev"]["tau"])
    _, dev_ref, _, _ = allantools.oadev(bias, rate=1 / 300, data_type="phase", taus=taus)
    np.testing.assert_allclose(doc["deviations"]["oadev"]["dev"], dev_ref, rtol=1e-9)
    for target, fragment in ((path, "no station 'XXXX'"), (F9P, "--station picks a station")):
        result = runner.invoke(app, ["stability", str(target), "--station", "XXXX", "--json"])
        assert result.exit_code == 2, result.output
        assert len(result.stderr.splitlines()) == 1 and fragment in result.stderr and str(target) in result.stderr


@pytest.mark.parametrize("relative, fragment", [("rinex/rtklib/07590920.05o", "clock-bias detection in identification mode, given a navigation file"),
                                                ("rinex/rtklib/07590920.05n", "nav file holds no receiver epochs"),
                                                ("gpsd/ublox-neo-m8t.log", "no UBX NAV-CLOCK message")])
def test_stability_on_a_recording_without_a_clock_says_what_to_do_in_one_line(relative, fragment):
    path = receivers_dir() / relative
    result = runner.invoke(app, ["stability", str(path), "--json"])
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and fragment in lines[0], result.stderr
