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
    assert sorted(p.name for p in out.iterdir()) == ["adev.png", "holdover.png", "report.html", "summary.json",
                                                    "time_error.png"]
    # the disciplined output is far better than the free-running oscillator after a 2-hour run
    assert doc["time_error_rms_ns"] < 30


@pytest.mark.parametrize("args, needle", [
    (["--rate", "-1"], "--rate"),
    (["--gdop-max", "0.5"], "--gdop-max"),
    (["--controller", "lqr"], "--controller"),
    (["--dac-bits", "0"], "--dac-bits"),
    (["--environment", "moon"], "--environment"),
    (["--duration", "-5"], "--duration"),
    (["--design", "guess"], "--design"),
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


def _refusal(res, name: str, line: int | None = None) -> str:
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and name in lines[0], lines
    if line is not None:
        assert f"{name}:{line}" in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("case, values, line, words", [
    # line numbers in the file: a header line, then sample k on line k + 2
    ("hz", lambda t, n: 10e6 + 1e-3 * n, 2, "order 1e+07"),
    ("ns", lambda t, n: 5.0 + n, 2, "ns or us"),
    ("us", lambda t, n: 0.3 + 0.005 * n, None, "from the record's median"),
    ("ramp-1ppm", lambda t, n: 1e-6 * t + 5e-9 * n, 2, "from the record's median"),
    ("ramp-2e-9", lambda t, n: 2e-9 * t + 5e-9 * n, 4001, "drifts by 2"),
    ("fractional-frequency", lambda t, n: 1e-11 * n, 3, "fractional-frequency"),
])
def test_a_reference_that_is_not_a_1pps_phase_in_seconds_is_refused_naming_file_and_line(tmp_path, case, values, line,
                                                                                          words):
    t = np.arange(4000, dtype=float)
    n = np.random.default_rng(1).standard_normal(4000)
    path = _write(tmp_path / f"{case}.txt.gz", values(t, n))
    message = _refusal(_run("--reference", str(path), "--json"), f"{case}.txt.gz", line)
    assert words in message


def test_a_1pps_phase_with_a_ns_unit_header_is_read_as_such_and_accepted(tmp_path):
    n = np.random.default_rng(2).standard_normal(4000)
    path = tmp_path / "ns.csv"
    path.write_text("t_s,phase_ns\n" + "".join(f"{i},{280.0 + 5.0 * v}\n" for i, v in enumerate(n)))
    res = _run("--reference", str(path), "--json")
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["duration_s"] == 4000


@pytest.mark.parametrize("option", [["--receivers", "2"], ["--environment", "urban-canyon"], ["--dac-bits", "12"],
                                    ["--gdop-max", "3"], ["--fusion", "selection"], ["--design", "datasheet"],
                                    ["--integrity-pfa", "1e-4"],
                                    ["--duration", "7200"]])
def test_options_that_do_not_apply_to_a_reference_record_are_refused_naming_them(tmp_path, option):
    path = _write(tmp_path / "ref.txt.gz", 5e-9 * np.random.default_rng(0).standard_normal(4000))
    message = _refusal(_run("--reference", str(path), *option), option[0])
    assert "not used with --reference" in message


@pytest.mark.parametrize("oscillator", ["tcxo", "rb", "csac"])
def test_every_oscillator_preset_runs_on_the_command_line(oscillator):
    res = _run("--oscillator", oscillator, "--duration", "3600", "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["oscillator"] == oscillator and doc["locked_over_threshold_seconds"] == 0


def test_an_unknown_oscillator_is_refused_naming_the_option():
    _refusal(_run("--oscillator", "maser", "--duration", "3600"), "--oscillator")


def test_a_pi_loop_bandwidth_past_the_stability_edge_is_refused_naming_the_option(tmp_path):
    # 0.3 Hz passed the option's (0, 0.5] range and then failed deep inside the servo naming kp.
    result = _run("--controller", "pi", "--loop-bandwidth", "0.3", "--duration", "3600", "--out", str(tmp_path / "out"))
    assert result.exit_code == 2
    assert "--loop-bandwidth" in result.output and "0.1318" in result.output and "kp" not in result.output
    assert not (tmp_path / "out").exists()
