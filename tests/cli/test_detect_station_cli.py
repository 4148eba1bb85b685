"""`chronofuse detect OBS --nav NAV --position X,Y,Z` on a real RINEX 3 station (Hatanaka, gzipped): every
code tested, the test chosen on the command line, a one-line refusal for bad options."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from _helpers import igs_station_catalogue

from chronofuse.cli.main import build_app

runner = CliRunner()
app = build_app(("detect",))


def _args(name: str, *extra):
    st = igs_station_catalogue()[name]
    position = ",".join(f"{v:.4f}" for v in st.reference_arp_m)
    navs = [arg for path in st.nav_paths for arg in ("--nav", str(path))]  # a day across two files: --nav twice
    return [str(st.obs_path), *navs, "--position", position, *map(str, extra)]


@pytest.mark.slow  # a whole day of a real station
@pytest.mark.parametrize("test", ["chi-square", "glr"])
def test_a_clean_rinex3_station_is_ok_with_every_code_tested(test):
    result = runner.invoke(app, ["detect", *_args("NYA1", "--train", 21600, "--codes", "G C1C,G C2W", "--test", test,
                                                  "--json")])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["state"] == "ok" and doc["test"] == test
    assert doc["codes"] == ["G C1C", "G C2W"] and doc["faulty"] == []
    assert doc["receiver_clock"]["state"] == "ok" and doc["position_offset_m"] < 10.0


@pytest.mark.slow  # a whole day of a real station
def test_a_real_satellite_fault_is_named_on_the_command_line():
    """BOR1's G08 on 2024-02-04: from about 21 h its channels leave the others by hundreds of sigma (window
    statistics up to 2e4); named alone, exit 1."""
    result = runner.invoke(app, ["detect", *_args("BOR1", "--train", 21600, "--codes", "G C1C,G C2W", "--json")])
    assert result.exit_code == 1, result.output
    doc = json.loads(result.stdout)
    assert {f["channel"] for f in doc["faulty"]} == {"G08"} and doc["receiver_clock"]["state"] == "ok"
    assert doc["n_tested"] > 0.9 * (doc["n_epochs"] - doc["n_training"])


def _one_line(result, *words):
    assert result.exit_code == 2, result.output
    assert len(result.output.strip().splitlines()) == 1, result.output
    assert all(word in result.output for word in words), result.output


def test_a_rinex3_station_without_training_or_with_an_unknown_test_is_refused_in_one_line():
    _one_line(runner.invoke(app, ["detect", *_args("BOR1", "--train", 3600, "--test", "cusum")]), "--test", "'cusum'")
    _one_line(runner.invoke(app, ["detect", *_args("BOR1", "--train", 3600, "--elevation-mask-deg", 90)]),
              "--elevation-mask-deg")
    result = runner.invoke(app, ["detect", *_args("BOR1", "--h0", 1e-11, "--hm2", 1e-22, "--sigma-rho", 1)])
    assert result.exit_code == 2 and "--train" in result.output and len(result.output.strip().splitlines()) == 1
    _one_line(runner.invoke(app, ["detect", *_args("BOR1", "--train", 3600, "--codes", "G C9Z")]), "--codes", "G C9Z")
