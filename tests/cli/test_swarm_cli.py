"""`chronofuse swarm run`: the JSON document is the library's result in ns; bad input is one line, exit 2."""

import json

import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.experiments.swarm import LinkScenario, run_link
from chronofuse.models.link import LinkModel

runner = CliRunner()
SMALL = ["--exchanges", "300", "--trials", "2", "--seed", "4"]


def test_swarm_run_json_is_the_library_result_in_nanoseconds():
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "rtt-rvc,ours-doppler", "--velocity", "1500",
                                 "--snr", "8", *SMALL, "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert set(doc) >= {"rmse_ns", "pcrb_ns", "convergence_epochs", "overhead", "urt_mode", "scenario"}
    lib = run_link(LinkScenario(velocity_m_s=1500.0, exchanges=300, link=LinkModel(snr_db=8.0)),
                   ["rtt-rvc", "ours-doppler"], trials=2, seed=4)
    for name in ("rtt-rvc", "ours-doppler"):
        assert doc["rmse_ns"][name] == pytest.approx(lib["rmse_s"][name] * 1e9, rel=1e-12)
    assert doc["pcrb_ns"]["rms"] == pytest.approx(lib["pcrb_s"]["rms"] * 1e9, rel=1e-12)
    assert doc["overhead"]["messages_per_s"] == 200.0


def test_paper_urt_mode_with_a_true_offset_is_off_by_the_offset():
    args = ["swarm", "run", "--algorithm", "proposed-no-nn", "--true-offset", "1e-6", *SMALL, "--json"]
    paper = json.loads(runner.invoke(app, [*args, "--urt-mode", "paper"]).stdout)
    calibrated = json.loads(runner.invoke(app, [*args, "--urt-mode", "calibrated"]).stdout)
    assert paper["rmse_ns"]["proposed-no-nn"] > 900.0
    assert calibrated["rmse_ns"]["proposed-no-nn"] < 5.0


@pytest.mark.parametrize("args, option", [
    (["--distance", "-5"], "--distance"),
    (["--snr", "30"], "--snr"),
    (["--distance", "1500000"], "--reply-delay"),
    (["--algorithm", "nope"], "--algorithm"),
    (["--urt-mode", "guess"], "--urt-mode"),
    (["--toa-model", "magic"], "--toa-model"),
])
def test_bad_input_is_one_line_naming_the_option_with_exit_code_2(args, option):
    result = runner.invoke(app, ["swarm", "run", *args, "--exchanges", "50", "--trials", "1"])
    assert result.exit_code == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {option}"), result.stderr


def test_an_outage_reports_robustness_and_the_filters_recover():
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "ptp-mls,ours-doppler", "--outage", "100:200",
                                 "--true-offset", "1e-6", *SMALL, "--json"])
    assert result.exit_code == 0, result.output
    rob = json.loads(result.stdout)["robustness"]
    assert set(rob) == {"ptp-mls", "ours-doppler"}
    assert rob["ours-doppler"]["recovery_epochs"] is not None and rob["ours-doppler"]["recovery_epochs"] < 50
    bad = runner.invoke(app, ["swarm", "run", "--outage", "0:5", "--exchanges", "50", "--trials", "1"])
    assert bad.exit_code == 2 and bad.stderr.startswith("error: --outage == 0:5")


def test_swarm_run_and_network_write_their_document_with_out(tmp_path):
    for args in (["swarm", "run", "--algorithm", "rtt-rvc", "--trials", "2", "--exchanges", "100"],
                 ["swarm", "network", "--duration", "100", "--followers", "2"]):
        out = tmp_path / args[1]
        result = CliRunner().invoke(app, [*args, "--out", str(out), "--json", "--quiet"])
        assert result.exit_code == 0, result.output
        doc = json.loads(result.stdout)
        assert doc["files"] == [str(out / "summary.json")]
        assert json.loads((out / "summary.json").read_text()) == {k: v for k, v in doc.items() if k != "files"}
