"""The main job: a report folder whose numbers agree with the models and the analysis."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.experiments.main_job import run_scenario
from chronofuse.experiments.scenario import parse_scenario

SHORT = """
name = "short"
duration_s = 7200
seed = 11
[receivers]
scenario = "open-sky"
count = 2
"""


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    return run_scenario(parse_scenario(SHORT, "short.toml"), tmp_path_factory.mktemp("run"))


def test_the_report_folder_holds_json_csv_and_plots(report):
    names = {p.name for p in report.out_dir.iterdir()}
    assert {"summary.json", "timeseries.csv", "stability.csv", "time_error.png", "adev.png", "mtie.png"} <= names
    summary = json.loads((report.out_dir / "summary.json").read_text())
    assert set(summary["receivers"]) == {"rx1", "rx2"}
    assert summary["mask"]["name"] == "prtc-a"


def test_the_oscillator_in_the_report_agrees_with_its_theory_at_99_percent_confidence(report):
    import pandas as pd

    from chronofuse.analysis import stability

    osc = report.summary["oscillator"]
    x_s = pd.read_csv(report.out_dir / "timeseries.csv")["oscillator_x_ns"].to_numpy() * 1e-9
    dev = stability.oadev(x_s, 1.0, stability.tau_grid("decade", x_s.size, 1.0, "oadev"), ci=0.99)
    theory = np.interp(np.log(dev.tau_s), np.log(osc["theory"]["tau"]), osc["theory"]["adev"])
    inside = (theory >= dev.lo) & (theory <= dev.hi)
    assert inside[dev.tau_s <= 200].all(), (dev.tau_s, dev.lo, theory, dev.hi)


def test_the_same_scenario_and_seed_give_the_same_report(report, tmp_path):
    again = run_scenario(parse_scenario(SHORT, "short.toml"), tmp_path)
    assert (again.out_dir / "timeseries.csv").read_bytes() == (report.out_dir / "timeseries.csv").read_bytes()


def test_chronofuse_run_with_a_bad_scenario_names_the_key_and_exits_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("duration = 10\n")
    result = CliRunner().invoke(app, ["run", str(bad), "--out", str(tmp_path / "out")])
    assert result.exit_code == 2
    assert "bad.toml: duration: unknown key" in result.stderr


def test_every_statistic_a_scenario_may_name_is_in_the_report_as_the_library_computes_it(tmp_path):
    import pandas as pd

    from chronofuse.analysis import stability

    names = sorted(stability.STATISTICS)
    text = SHORT.replace("count = 2", "count = 1").replace("7200", "2000")
    text += "[analysis]\ndeviations = [" + ", ".join(f'"{n}"' for n in names) + "]\n"
    report = run_scenario(parse_scenario(text, "all.toml"), tmp_path)
    written = report.summary["receivers"]["rx1"]["deviations"]
    assert sorted(written) == names
    # the same statistics again, from the time series the report wrote (ns, 12 significant digits)
    x_s = pd.read_csv(report.out_dir / "timeseries.csv")["rx1_pps_error_ns"].to_numpy() * 1e-9
    for name in names:
        ours = stability.compute(name, x_s, 1.0, stability.tau_grid("decade", x_s.size, 1.0, name))
        np.testing.assert_allclose(written[name]["dev"], ours.dev, rtol=1e-6, err_msg=name)
    assert set(pd.read_csv(report.out_dir / "stability.csv")["statistic"]) == set(names) | {"oadev"}


def test_the_main_job_disciplines_the_ocxo_through_an_outage_and_a_swarm_follows_it(tmp_path):
    text = SHORT.replace("7200", "14400") + "[discipline]\noutage_start_s = 7200\noutage_s = 1800\n[swarm]\nfollowers = 2\n"
    report = run_scenario(parse_scenario(text, "chain.toml"), tmp_path)
    d, w = report.summary["discipline"], report.summary["swarm"]
    # The loop holds the OCXO within a few tens of ns of GNSS time, near the clairvoyant filter on the same data.
    assert d["time_error_rms_ns"] < 1.25 * d["optimal_rms_ns"] + 1.0
    assert d["holdover_s"] == 1800 and d["state_seconds"]["holdover"] >= 1800
    # Followers stay within a few ns of the leader (two-way links), and so carry the leader's own error to truth.
    assert len(w["to_leader_rms_ns"]) == 2 and max(w["to_leader_rms_ns"]) < 5.0
    assert abs(w["to_true_rms_ns"][0] - w["leader_to_true_rms_ns"]) < 5.0
    for name in ("swarm.png", "discipline/time_error.png", "discipline/adev.png", "discipline/holdover.png"):
        assert (tmp_path / name).stat().st_size > 0


def test_an_outage_past_the_end_of_the_run_is_refused_naming_the_key(tmp_path):
    from chronofuse.experiments.scenario import ScenarioError

    text = SHORT.replace("7200", "14400") + "[discipline]\noutage_start_s = 14000\noutage_s = 3600\n"
    with pytest.raises(ScenarioError, match="discipline.outage_start_s"):
        run_scenario(parse_scenario(text, "late.toml"), tmp_path)


def test_run_seed_replaces_the_scenarios_seed(report, tmp_path):
    other = tmp_path / "short.toml"
    other.write_text(SHORT.replace("seed = 11", "seed = 5"))
    result = CliRunner().invoke(app, ["run", str(other), "--seed", "11", "--out", str(tmp_path / "a"), "--json"])
    assert result.exit_code == 0, result.output
    assert (tmp_path / "a" / "timeseries.csv").read_bytes() == (report.out_dir / "timeseries.csv").read_bytes()
    refused = CliRunner().invoke(app, ["run", str(other), "--seed", "-1", "--out", str(tmp_path / "b")])
    assert refused.exit_code == 2 and refused.stderr == "error: --seed == -1, must be >= 0\n"
