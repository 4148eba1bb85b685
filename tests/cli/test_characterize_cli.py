"""`chronofuse characterize`: the JSON document and report folder on a real record, the oscillator file that
`gnssdo --oscillator-file` takes, and one-line refusals (exit 2) naming the file."""

import json
from pathlib import Path

import numpy as np
import typer
from typer.testing import CliRunner

from chronofuse.cli import characterize as characterize_cli
from chronofuse.cli import gnssdo as gnssdo_cli

runner = CliRunner()
app = typer.Typer()
characterize_cli.register(app)
gnssdo_cli.register(app)


@app.callback()
def _root() -> None:
    """Local app holding only the commands under test."""


OCXO = Path(__file__).resolve().parents[1] / "data" / "stability" / "ocxo" / "ocxo_frequency.txt"


def test_the_ocxo_record_gives_a_fitting_model_a_report_and_an_oscillator_file_gnssdo_runs_with(tmp_path):
    out = tmp_path / "rep"
    res = runner.invoke(app, ["characterize", str(OCXO), "--kind", "freq", "--rate", "1", "--nominal-hz", "1e7",
                              "--trials", "20", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["fits"] and all(doc["adev"]["inside"])
    assert [row["horizon_s"] for row in doc["holdover"]] == [3600.0, 14400.0, 86400.0]
    assert {"crossover_s", "kalman_gains", "pi"} <= set(doc["loop"])
    assert sorted(p.name for p in out.iterdir()) == ["adev.png", "characterization.json", "oscillator.json"]
    osc = json.loads((out / "oscillator.json").read_text())
    assert osc["h"] == doc["h"]
    res = runner.invoke(app, ["gnssdo", "--oscillator-file", str(out / "oscillator.json"), "--duration", "7200",
                              "--design", "datasheet", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["oscillator"] == "ocxo_frequency"


def _refused(res, name: str) -> None:
    assert res.exit_code == 2, res.output
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and name in lines[0] and lines[0].startswith("error:"), res.output


def test_a_record_too_short_is_refused_naming_the_file(tmp_path):
    short = tmp_path / "short.txt"
    np.savetxt(short, np.cumsum(np.random.default_rng(1).normal(size=400)) * 1e-9)
    res = runner.invoke(app, ["characterize", str(short), "--rate", "1"])
    _refused(res, "short.txt")
    assert "too short to fit" in res.output


def test_a_frequency_record_given_as_phase_is_refused_naming_the_file(tmp_path):
    res = runner.invoke(app, ["characterize", str(OCXO), "--kind", "phase", "--rate", "1"])
    _refused(res, "ocxo_frequency.txt")
    assert "frequency record given as phase" in res.output and "--kind" in res.output
    fractional = tmp_path / "fractional.txt"
    values = np.loadtxt(OCXO) / 1e7 - 1.0
    np.savetxt(fractional, values)
    res = runner.invoke(app, ["characterize", str(fractional), "--kind", "phase", "--rate", "1"])
    _refused(res, "fractional.txt")


def test_a_bad_oscillator_file_is_refused_naming_it(tmp_path):
    bad = tmp_path / "osc.json"
    bad.write_text('{"name": "x"}')
    _refused(runner.invoke(app, ["gnssdo", "--oscillator-file", str(bad)]), "osc.json")
    bad.write_text("not json")
    _refused(runner.invoke(app, ["gnssdo", "--oscillator-file", str(bad)]), "osc.json")
    res = runner.invoke(app, ["gnssdo", "--oscillator-file", str(bad), "--oscillator", "rb"])
    _refused(res, "--oscillator-file")


def test_a_temperature_column_gives_the_tempco_and_the_oscillator_file_keeps_it(tmp_path):
    from chronofuse.models.oscillator import OscillatorModel, PowerLaw, simulate_oscillator

    n = 60_000
    temp = 300.0 + 2.0 * np.sin(2 * np.pi * np.arange(n) / 43_200.0)
    model = OscillatorModel("t", 10e6, PowerLaw(h2=2e-21, h0=2e-23, hm1=5e-25, hm2=2e-28), 3e-16, 3e-11, 0.0, 1, 1.0,
                            "test")
    x = simulate_oscillator(model, float(n), 1.0, 3, temperature_K=temp).x_s[0]
    path = tmp_path / "withtemp.txt"
    np.savetxt(path, np.column_stack([np.arange(n), x, temp - 273.15]), header="t_s phase_s temp_c", comments="")
    out = tmp_path / "rep"
    res = runner.invoke(app, ["characterize", str(path), "--column", "phase_s", "--temperature-column", "temp_c",
                              "--trials", "20", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert abs(doc["temp_coeff_per_K"] - 3e-11) < 4 * doc["temp_coeff_sigma_per_K"]
    osc = json.loads((out / "oscillator.json").read_text())
    assert osc["temp_coeff_per_K"] == doc["temp_coeff_per_K"] and abs(osc["temp_ref_K"] - 300.0) < 0.5
    res = runner.invoke(app, ["characterize", str(path), "--column", "phase_s", "--temperature-column", "nope"])
    _refused(res, "withtemp.txt")
