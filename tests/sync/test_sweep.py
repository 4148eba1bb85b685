"""Sweeps: a real Dask scheduler with two workers on loopback gives the serial run's numbers bit for bit;
the summary's intervals and ratios to the bound."""

import json

import pandas as pd
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app
from chronofuse.experiments.swarm import LinkScenario
from chronofuse.experiments.sweep import run_sweep, run_task, summarize, sweep_tasks, value_key

BASE = LinkScenario(exchanges=200)
ALGS = ("rtt-rvc", "doppler-kf")


def test_a_point_has_the_same_numbers_whichever_other_values_are_swept():
    a = sweep_tasks(BASE, "velocity", [200.0, 800.0], ALGS, trials=6, seed=3, chunk_trials=4, urt_mode="paper")
    b = sweep_tasks(BASE, "velocity", [800.0], ALGS, trials=6, seed=3, chunk_trials=4, urt_mode="paper")
    assert [t["trials"] for t in a] == [4, 2, 4, 2]
    assert a[2]["seed"].spawn_key == b[0]["seed"].spawn_key == (value_key(800.0), 0)
    pd.testing.assert_frame_equal(run_task(a[3]), run_task(b[1]), check_exact=True)


def test_the_summary_carries_intervals_that_contain_the_rmse_and_a_ratio_to_the_bound():
    table = run_sweep(BASE, "velocity", [400.0], ALGS, trials=12, seed=5, chunk_trials=6, scheduler="serial")
    summary = summarize(table)
    for row in summary.to_dict(orient="records"):
        assert row["rmse_lo_ns"] <= row["rmse_ns"] <= row["rmse_hi_ns"]
        assert row["ratio_lo"] <= row["ratio"] <= row["ratio_hi"]
        assert row["ratio"] == pytest.approx(row["rmse_ns"] / row["bound_rms_ns"], rel=1e-12)
    # the trials have their own calibrations: their bounds differ
    assert table["bound_rms_ns"].nunique() > 1


@pytest.mark.slow
def test_a_real_scheduler_with_two_loopback_workers_reproduces_the_serial_sweep_bit_for_bit():
    from distributed import LocalCluster

    kwargs = dict(trials=4, seed=11, chunk_trials=2, urt_mode="calibrated")
    serial = run_sweep(BASE, "snr", [6.0, 14.0], ALGS, scheduler="serial", **kwargs)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        seen = []
        remote = run_sweep(BASE, "snr", [6.0, 14.0], ALGS, scheduler=cluster.scheduler_address,
                           progress=lambda done, total: seen.append((done, total)), **kwargs)
    pd.testing.assert_frame_equal(serial, remote, check_exact=True)
    assert seen[-1] == (8, 8)
    assert len(serial) == 2 * 2 * 4
    assert set(summarize(serial)["trials"]) == {4}


def test_an_unreachable_scheduler_is_a_one_line_error_with_exit_code_2(tmp_path):
    runner = CliRunner()
    result = runner.invoke(app, ["swarm", "sweep", "--param", "velocity", "--values", "200", "--trials", "1",
                                 "--exchanges", "100", "--algorithm", "rtt-rvc", "--urt-mode", "paper",
                                 "--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path)],
                           env={"CHRONOFUSE_PROGRESS_S": "1e9"})  # a loaded machine's plain progress line is not the error
    assert result.exit_code == 2
    lines = [x for x in result.stderr.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: --scheduler"), result.stderr


def test_the_library_s_scheduler_error_names_its_parameter_not_a_flag():
    from chronofuse.experiments.sweep import _client
    from chronofuse.validation import ChronofuseError

    with pytest.raises(ChronofuseError, match="^scheduler == 'nope'"):
        _client("nope", 1)


def test_sweep_writes_a_tidy_table_a_summary_and_a_figure(tmp_path):
    runner = CliRunner()
    result = runner.invoke(app, ["swarm", "sweep", "--param", "urt", "--values", "0,4e-8", "--trials", "2",
                                 "--exchanges", "150", "--algorithm", "rtt-rvc", "--urt-mode", "paper", "--urt-sigma", "0",
                                 "--scheduler", "serial", "--out", str(tmp_path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    table = pd.read_parquet(tmp_path / "sweep.parquet")
    assert list(table.columns) == ["param", "value", "algorithm", "trial", "rmse_ns", "bound_rms_ns"]
    assert (tmp_path / "sweep.png").stat().st_size > 0
    rmse = {row["value"]: row["rmse_ns"] for row in doc["summary"]}
    # RTT-RVC has no URT compensation: a 40 ns URT biases it by about 20 ns (the paper's eq. 17).
    assert rmse[4e-8] - rmse[0.0] == pytest.approx(20.0, abs=2.0)
