"""`chronofuse gnssdo`: the JSON document, the report folder, and one-line refusals of bad configurations."""

import gzip
import json

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import gnssdo as gnssdo_cli

runner = CliRunner()
app = typer.Typer()
gnssdo_cli.register(app)


@app.callback()
def _root() -> None:
    """Local app holding only the command under test."""


KEYS = {"time_error_rms_ns", "time_error_pp_ns", "convergence_s", "state_seconds", "optimal_rms_ns", "adev"}


def _run(*args):
    return runner.invoke(app, ["gnssdo", *args])


def test_a_short_outage_run_prints_one_json_document_with_every_key_and_writes_the_report(tmp_path):
    out = tmp_path / "rep"
    res = _run("--environment", "outage", "--duration", "7200", "--trials", "2", "--receivers", "2", "--out", str(out),
               "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert KEYS <= set(doc) and {"holdover_error_ns", "holdover_s"} <= set(doc)
    assert doc["holdover_s"] == pytest.approx(1800.0)
    assert set(doc["adev"]) == {"free_run", "gnss", "disciplined"}
    assert all(set(v) == {"tau", "dev"} for v in doc["adev"].values())
    assert doc["state_seconds"]["holdover"] == pytest.approx(1800.0)
    assert sorted(p.name for p in out.iterdir()) == ["adev.png", "holdover.png", "summary.json", "time_error.png"]
    # the disciplined output is far better than the free-running oscillator after a 2-hour run
    assert doc["time_error_rms_ns"] < 30


@pytest.mark.parametrize("args, needle", [
    (["--rate", "-1"], "--rate"),
    (["--gdop-max", "0.5"], "--gdop-max"),
    (["--controller", "lqr"], "--controller"),
    (["--dac-bits", "0"], "--dac-bits"),
    (["--environment", "moon"], "--environment"),
    (["--duration", "-5"], "--duration"),
])
def test_a_bad_configuration_is_refused_with_one_line_naming_the_option(args, needle):
    res = _run(*args)
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and needle in lines[0]


def test_a_scenario_with_no_usable_receiver_stays_in_free_run_and_says_so():
    # GDOP is never below 1: with --gdop-max 1 no epoch qualifies.
    res = _run("--duration", "3600", "--gdop-max", "1", "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["no_usable_receiver"] is True
    assert doc["state_seconds"]["free_run"] == 3600.0
    res = _run("--duration", "3600", "--gdop-max", "1")
    assert "free-run" in res.output


def _write(path, values, header="# phase (s)\n"):
    with gzip.open(path, "wt") as fh:
        fh.write(header)
        for v in values:
            fh.write(f"{float(v)!r}\n")
    return path


def test_a_reference_record_with_a_gap_is_refused_naming_file_and_line(tmp_path):
    x = 5e-9 * np.random.default_rng(0).standard_normal(4000)
    x[1234] = np.nan
    path = _write(tmp_path / "ref.txt.gz", x)
    res = _run("--reference", str(path), "--json")
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "ref.txt.gz:1236" in lines[0] and "gap" in lines[0]


def test_a_reference_record_at_the_wrong_rate_is_refused_naming_file_and_line(tmp_path):
    path = tmp_path / "ref.csv"
    path.write_text("t_s,phase_s\n" + "".join(f"{2 * i},{1e-9 * i}\n" for i in range(4000)))
    res = _run("--reference", str(path))
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "ref.csv:" in lines[0] and "rate" in lines[0]


@pytest.mark.slow
def test_the_real_gps_record_disciplines_a_simulated_ocxo_within_twice_the_adev_envelope(data_dir):
    data = data_dir / "stability" / "gps" / "gps_1pps_phase_data.txt.gz"
    res = _run("--reference", str(data), "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    a = doc["adev"]
    envelope = np.fmin(np.array(a["free_run"]["dev"]), np.array(a["gnss"]["dev"]))
    assert np.all(np.array(a["disciplined"]["dev"]) < 2.0 * envelope)
    assert doc["duration_s"] == 241_218
