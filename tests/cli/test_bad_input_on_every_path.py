"""Bad input found by the issue-22 audit: the same refusal (exit 2, one line naming the file and line or the
option) on every path, never a "bug" (exit 70) on one path and an input error on another, and never a
monitor that runs on settings or files it cannot watch and reports success."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.cli.main import app

from _recordings import step

runner = CliRunner()
T0_NS = 1_391_140_000_000_000_123  # an odd-nanosecond time tag


def _csv(tmp_path, order) -> tuple:
    rng = np.random.default_rng(7)
    bias = np.cumsum(rng.normal(0.0, 1e-9, 900))
    rows = [f"{(T0_NS + k * 1_000_000_000) // 10**9}.{T0_NS % 10**9:09d},{bias[k]:.12e}" for k in order]
    path = tmp_path / "clock.csv"
    path.write_text("time,clock_bias_s\n" + "\n".join(rows) + "\n")
    return path, path.read_text()


@pytest.mark.parametrize("name, order", [("repeated", [*range(701), 700, *range(701, 900)]),
                                         ("backwards", [*range(701), 0, *range(701, 900)])])
def test_a_time_column_that_does_not_increase_is_the_same_input_error_on_every_detect_path(tmp_path, name, order):
    path, text = _csv(tmp_path, order)
    runs = {"FILE": runner.invoke(app, ["detect", str(path), "--train", "300", "--json"]),
            "-": runner.invoke(app, ["detect", "-", "--train", "300", "--json"], input=text),
            "--json-lines": runner.invoke(app, ["detect", str(path), "--train", "300", "--json-lines"]),
            "- --json-lines": runner.invoke(app, ["detect", "-", "--train", "300", "--json-lines"], input=text)}
    for how, result in runs.items():
        assert result.exit_code == 2, (how, result.output)
        message = result.output.strip().splitlines()[-1]
        assert message.startswith("error: ") and ":703: time is not increasing (" in message, (how, message)
        assert " ns then " in message  # exact integer ns: two tags 1 ns apart do not print alike


@pytest.mark.parametrize("options, named", [(["--pfa", "2"], "--pfa"), (["--window", "0"], "--window"),
                                            (["--gdop-max", "-1"], "--gdop-max"),
                                            (["--h0", "-1", "--hm2", "1e-22", "--sigma-rho", "1"], "--h0")])
def test_the_monitor_refuses_a_setting_no_receiver_could_be_watched_with(tmp_path, options, named):
    recording = tmp_path / "step.ubx"
    recording.write_bytes(step())
    result = runner.invoke(app, ["monitor", "--replay", str(recording), "--replay-speed", "1e6", "--train", "300",
                                 "--json", *options])
    assert result.exit_code == 2, result.output
    assert f"error: {named}" in result.output and "a bug" not in result.output


def test_the_monitor_refuses_to_replay_a_clock_bias_text_file_instead_of_reporting_no_epochs(tmp_path):
    path, _ = _csv(tmp_path, range(900))
    result = runner.invoke(app, ["monitor", "--replay", str(path), "--replay-speed", "1e6", "--json"])
    assert result.exit_code == 2, result.output
    assert "not a receiver recording" in result.output and str(path) in result.output
