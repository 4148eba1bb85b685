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
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "rtt-rvc,doppler-kf", "--velocity", "1500",
                                 "--snr", "8", "--common-velocity", "200", "--latitude", "40", *SMALL, "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert set(doc) >= {"rmse_ns", "rmse_ci_ns", "ratio_to_bound", "ratio_ci", "bound_ns", "convergence_epochs",
                        "overhead", "urt_mode", "scenario", "calibration"}
    lib = run_link(LinkScenario(velocity_m_s=1500.0, exchanges=300, link=LinkModel(snr_db=8.0), common_velocity_m_s=200.0,
                                latitude_deg=40.0), ["rtt-rvc", "doppler-kf"], trials=2, seed=4)
    for name in ("rtt-rvc", "doppler-kf"):
        assert doc["rmse_ns"][name] == pytest.approx(lib["rmse_s"][name] * 1e9, rel=1e-12)
        assert doc["ratio_to_bound"][name] == pytest.approx(lib["ratio"][name], rel=1e-12)
    assert doc["bound_ns"]["rms"] == pytest.approx(lib["bound_s"]["rms"] * 1e9, rel=1e-12)
    assert doc["overhead"]["messages_per_s"] == 200.0


def test_paper_urt_mode_with_a_true_offset_is_off_by_the_offset():
    args = ["swarm", "run", "--algorithm", "rtt-rvc-kf", "--offset-mean", "1e-6", "--offset-sigma", "1e-7", *SMALL,
            "--json"]
    paper = json.loads(runner.invoke(app, [*args, "--urt-mode", "paper"]).stdout)
    calibrated = json.loads(runner.invoke(app, [*args, "--urt-mode", "calibrated"]).stdout)
    assert paper["rmse_ns"]["rtt-rvc-kf"] > 900.0
    assert calibrated["rmse_ns"]["rtt-rvc-kf"] < 5.0


def test_an_old_algorithm_name_is_one_line_with_its_new_name():
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "ours-doppler", "--exchanges", "50", "--trials", "1"])
    assert result.exit_code == 2 and "now called 'doppler-kf'" in result.stderr


@pytest.mark.parametrize("args, option", [
    (["--distance", "-5"], "--distance"),
    (["--snr", "30"], "--snr"),
    (["--distance", "1500000"], "--reply-delay"),
    (["--algorithm", "nope"], "--algorithm"),
    (["--urt-mode", "guess"], "--urt-mode"),
    (["--toa-model", "magic"], "--toa-model"),
    (["--offset-sigma", "-1"], "--offset-sigma"),
    (["--manoeuvre", "loop"], "--manoeuvre"),
    (["--nlos", "2"], "--nlos"),
    (["--calibration-duration", "-1"], "--calibration-duration"),
    (["--algorithm", "rtt-rvc-kf-numba", "--urt-mode", "paper"], "--urt-mode"),
    (["--algorithm", "doppler-kf", "--manoeuvre", "turn", "--velocity", "0"], "--velocity"),
])
def test_bad_input_is_one_line_naming_the_option_with_exit_code_2(args, option):
    result = runner.invoke(app, ["swarm", "run", *args, "--exchanges", "50", "--trials", "1"])
    assert result.exit_code == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {option}"), result.stderr


def test_a_cut_off_of_a_node_that_does_not_exist_is_one_line_naming_the_option_with_exit_code_2():
    result = runner.invoke(app, ["swarm", "network", "--nodes", "3", "--duration", "30", "--cut-off", "7:0:10"])
    assert result.exit_code == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: --cut-off == ") and "--nodes" in lines[0], result.stderr


def test_an_outage_reports_robustness_and_the_filters_recover():
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "ptp-mls,doppler-kf", "--outage", "100:200",
                                 "--offset-mean", "1e-6", *SMALL, "--json"])
    assert result.exit_code == 0, result.output
    rob = json.loads(result.stdout)["robustness"]
    assert set(rob) == {"ptp-mls", "doppler-kf"}
    assert rob["doppler-kf"]["recovery_epochs"] is not None and rob["doppler-kf"]["recovery_epochs"] < 50
    bad = runner.invoke(app, ["swarm", "run", "--outage", "0:5", "--exchanges", "50", "--trials", "1"])
    assert bad.exit_code == 2 and bad.stderr.startswith("error: --outage == 0:5")


def test_swarm_network_reports_each_node_s_state_uncertainty_and_time_error_statistics():
    result = runner.invoke(app, ["swarm", "network", "--nodes", "5", "--duration", "60", "--leader-loss-at", "30",
                                 "--cut-off", "2:2:60", "--seed", "3", "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["nodes"] == 5 and doc["leader_changes"][0] == {"exchange": 30, "leader": -1}
    states = {r["node"]: r["state_end"] for r in doc["per_node"]}
    assert states[2] == "holdover" and "leader" in states.values()
    row = next(r for r in doc["per_node"] if r["state_end"] == "locked")
    assert {"rms_ns", "p95_abs_ns", "p99_abs_ns", "max_abs_ns"} <= set(row["to_leader"])
    assert row["mtie"]["tau_s"] and row["mask"]["name"] == "prtc-b"
    bad = runner.invoke(app, ["swarm", "network", "--cut-off", "x", "--duration", "10"])
    assert bad.exit_code == 2 and bad.stderr.startswith("error: --cut-off")


def test_swarm_run_and_network_write_their_document_with_out(tmp_path):
    for args in (["swarm", "run", "--algorithm", "rtt-rvc", "--trials", "2", "--exchanges", "100"],
                 ["swarm", "network", "--duration", "60", "--nodes", "3"]):
        out = tmp_path / args[1]
        result = CliRunner().invoke(app, [*args, "--out", str(out), "--json", "--quiet"])
        assert result.exit_code == 0, result.output
        doc = json.loads(result.stdout)
        # swarm run also writes its HTML report (swarm network has none)
        assert doc["files"][0] == str(out / "summary.json")
        assert doc["files"][1:] == ([str(out / "report.html")] if args[1] == "run" else [])
        assert json.loads((out / "summary.json").read_text()) == {k: v for k, v in doc.items() if k != "files"}


def test_one_trial_gives_no_interval_and_says_so_naming_trials():
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "rtt-rvc", "--exchanges", "100", "--trials", "1",
                                 "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["rmse_ci_ns"]["rtt-rvc"] == [None, None] and doc["ratio_ci"]["rtt-rvc"] == [None, None]
    assert doc["rmse_ns"]["rtt-rvc"] > 0.0
    assert any(w.startswith("--trials == 1 is below 10") for w in doc["warnings"]), doc["warnings"]
    human = runner.invoke(app, ["swarm", "run", "--algorithm", "rtt-rvc", "--exchanges", "100", "--trials", "1"])
    assert human.exit_code == 0 and "warning: --trials == 1" in human.stdout
    words = human.stdout.split()  # the table may wrap "not available" over two lines
    assert words.count("not") >= 2 and words.count("available") >= 2 and "nan" not in human.stdout


def test_a_loss_its_bursts_cannot_reach_is_one_line_and_links_that_never_got_an_exchange_are_reported():
    bad = runner.invoke(app, ["swarm", "run", "--loss", "0.999", "--exchanges", "50", "--trials", "1"])
    assert bad.exit_code == 2
    lines = [line for line in bad.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: --loss == 0.999 needs --loss-burst >= 999"), bad.stderr
    result = runner.invoke(app, ["swarm", "run", "--loss", "0.999", "--loss-burst", "1000", "--exchanges", "120",
                                 "--trials", "12", "--algorithm", "rtt-rvc-kf,doppler-kf", "--json"])
    assert result.exit_code == 0, result.output
    assert "RuntimeWarning" not in result.stderr
    doc = json.loads(result.stdout)
    unscored = doc["unscored_trials"]["rtt-rvc-kf"]
    assert 0 < len(unscored) < 12 and doc["rmse_ns"]["rtt-rvc-kf"] > 0.0
    assert any(w.startswith(f"rtt-rvc-kf: {len(unscored)} of 12 trials had no estimate") for w in doc["warnings"])
    human = runner.invoke(app, ["swarm", "run", "--loss", "0.999", "--loss-burst", "1000", "--exchanges", "120",
                                "--trials", "12", "--algorithm", "rtt-rvc-kf"])
    assert human.exit_code == 0 and f"{12 - len(unscored)}/12" in human.stdout


def _one_line_error(result, start: str) -> None:
    assert result.exit_code == 2, result.output
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith(start), result.stderr


@pytest.mark.parametrize("args, start", [
    (["--cut-off", "1:50:10"], "error: --cut-off == 1:50:10, must be NODE:FROM:TO with 0 <= FROM < TO"),
    (["--cut-off", "9:1:2"], "error: --cut-off == 9:1:2, must be NODE:FROM:TO with NODE an existing node"),
    (["--cut-off", "1:a:b"], "error: --cut-off == '1:a:b', must be NODE:FROM:TO"),  # not an emoji for ":a:"
    (["--mean-down", "-1"], "error: --mean-down == -1.0, must be > 0"),  # checked with an infinite --mean-up too
    (["--mean-up", "0"], "error: --mean-up == 0.0, must be > 0"),
    (["--area", "0"], "error: --area == 0.0, must be > 0"),
    (["--leader-oscillator", "bogus"], "error: --leader-oscillator == 'bogus', must be one of"),
    (["--scheduler", "bogus"], "error: --scheduler == 'bogus', must be 'local', 'serial' or tcp://HOST:PORT"),
])
def test_bad_swarm_network_input_is_one_line_naming_its_own_option(args, start):
    _one_line_error(runner.invoke(app, ["swarm", "network", "--nodes", "3", "--duration", "30", *args]), start)


@pytest.mark.parametrize("args, start", [
    (["--calibration-duration", "1.5"], "error: --calibration-duration must be >= 2 s (two GNSS comparisons"),
    (["--offset-sigma", "-1"], "error: --offset-sigma == -1.0, must be >= 0"),
    (["--skew-mean", "1"], "error: --skew-mean == 1.0, must be <= 0.001"),
])
def test_bad_prior_and_calibration_input_is_worded_as_the_library_words_its_own(args, start):
    _one_line_error(runner.invoke(app, ["swarm", "run", *args, "--exchanges", "50", "--trials", "1"]), start)


def test_a_repeated_sweep_value_is_one_line_not_the_same_trials_counted_twice(tmp_path):
    result = runner.invoke(app, ["swarm", "sweep", "--param", "velocity", "--values", "0,0,0", "--trials", "1",
                                 "--exchanges", "50", "--scheduler", "serial", "--out", str(tmp_path)])
    _one_line_error(result, "error: --values == 0,0,0 repeats 0: give each value once")


def test_training_on_an_absent_gpu_is_refused_naming_device_before_the_data_set_is_built(monkeypatch, tmp_path):
    torch = pytest.importorskip("torch")
    import chronofuse.experiments.swarm_training as training

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)

    def no_data_set(**kwargs):
        raise AssertionError("the data set was built before the device was checked")

    monkeypatch.setattr(training, "residual_dataset", no_data_set)
    result = runner.invoke(app, ["swarm", "train", "--device", "cuda", "--quick", "--out", str(tmp_path)])
    _one_line_error(result, "error: --device == 'cuda', but no CUDA device is available")


def test_true_offset_fixes_every_trial_s_offset_and_a_non_finite_one_is_one_line():
    result = runner.invoke(app, ["swarm", "run", "--algorithm", "doppler-kf,null", "--true-offset", "5e-6",
                                 "--exchanges", "100", "--trials", "2", "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["true_offset_s"] == [5e-6, 5e-6]
    assert doc["rmse_ns"]["null"] == pytest.approx(5000.0, rel=0.01)  # the do-nothing error is the offset
    assert doc["rmse_ns"]["doppler-kf"] < 5.0
    assert set(doc["bound_scored_ns"]) == {"doppler-kf", "null"}
    bad = runner.invoke(app, ["swarm", "run", "--true-offset", "nan", "--exchanges", "50", "--trials", "1"])
    assert bad.exit_code == 2
    lines = [line for line in bad.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "--true-offset == nan" in lines[0], bad.stderr
