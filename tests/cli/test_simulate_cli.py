"""`chronofuse simulate`: files written, JSON shape, and theory that matches the library's."""

import json

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from chronofuse.analysis.theory import adev_theory
from chronofuse.cli.main import app
from chronofuse.models.oscillator_presets import preset

runner = CliRunner()


def test_simulate_oscillator_writes_phase_columns_and_prints_theory(tmp_path):
    out = tmp_path / "ocxo.csv"
    result = runner.invoke(app, ["simulate", "oscillator", "--oscillator", "ocxo", "--duration", "1000", "--rate", "1",
                                 "--seed", "3", "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert set(doc) == {"h", "drift", "theory", "out"}
    assert set(doc["h"]) == {"h2", "h1", "h0", "hm1", "hm2"}
    frame = pd.read_csv(out)
    assert out.read_text().splitlines()[0] == "t_s,x_s" and len(frame) == 1000
    model = preset("ocxo")
    expected = adev_theory(model.h, np.array(doc["theory"]["tau"]), 1.0, model.drift_per_s)
    np.testing.assert_allclose(doc["theory"]["adev"], expected, rtol=1e-12)


def test_h_overrides_replace_the_preset_coefficients(tmp_path):
    out = tmp_path / "o.csv"
    result = runner.invoke(app, ["simulate", "oscillator", "--duration", "100", "--h0", "2e-22", "--hm2", "0",
                                 "--drift", "0", "--out", str(out), "--json"])
    doc = json.loads(result.stdout)
    assert doc["h"]["h0"] == 2e-22 and doc["h"]["hm2"] == 0 and doc["drift"] == 0


def test_the_same_seed_gives_the_same_file(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    for out in (a, b):
        runner.invoke(app, ["simulate", "oscillator", "--duration", "200", "--seed", "9", "--out", str(out)])
    assert a.read_bytes() == b.read_bytes()


def test_simulate_receiver_writes_one_row_per_receiver_and_second(tmp_path):
    out = tmp_path / "rx.csv"
    result = runner.invoke(app, ["simulate", "receiver", "--environment", "urban-canyon", "--duration", "600",
                                 "--receivers", "3", "--seed", "1", "--out", str(out), "--json"])
    assert result.exit_code == 0, result.output
    frame = pd.read_csv(out)
    assert len(frame) == 3 * 600
    assert {"t_s", "receiver", "pps_error_ns", "qerr_ns", "fix", "gdop", "utc_s", "leap_s"} <= set(frame.columns)
    doc = json.loads(result.stdout)
    assert len(doc["summary"]) == 3


def test_a_bad_preset_or_scenario_is_a_one_line_error_with_exit_code_2(tmp_path):
    result = runner.invoke(app, ["simulate", "oscillator", "--oscillator", "hydrogen", "--out", str(tmp_path / "x.csv")])
    assert result.exit_code == 2 and "hydrogen" in result.stderr
    result = runner.invoke(app, ["simulate", "receiver", "--environment", "moon", "--out", str(tmp_path / "x.csv")])
    assert result.exit_code == 2 and "moon" in result.stderr
    result = runner.invoke(app, ["simulate", "oscillator", "--rate", "-1", "--out", str(tmp_path / "x.csv")])
    assert result.exit_code == 2 and "rate" in result.stderr
