"""A reading option that does not apply to the input (``--column`` on a UBX recording, ``--rate`` on a RINEX clock
product, ``--codes`` on anything but RINEX observations, ``--follow`` on a file read whole) is refused naming it,
exit 2, the same line on ``detect FILE`` and ``detect -``; where it applies it is used (negative verdicts)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from chronofuse.cli import detect as detect_cli

from _helpers import receivers_dir  # noqa: E402
from _recordings import step  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
runner = CliRunner()
app = typer.Typer()
detect_cli.register(app)
TRAIN = ["--train", "300"]


@app.callback()
def _root() -> None:
    """Local app holding the command under test."""


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("inputs")
    ubx = folder / "step.ubx"
    ubx.write_bytes(step())
    x = np.cumsum(np.random.default_rng(3).normal(0, 1e-9, 900))
    csv = folder / "bias.csv"
    csv.write_text("t_s,other,bias_s\n" + "".join(f"{k},{k * 2},{v:.15e}\n" for k, v in enumerate(x)))
    return {"ubx": ubx, "csv": csv, "clk": receivers_dir() / "rinex/rtklib/igs15904.clk"}


def _piped(path: Path, args: list[str]) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    with open(path, "rb") as stdin:
        return subprocess.run([sys.executable, "-m", "chronofuse.cli.main", "detect", "-", *args], stdin=stdin,
                              capture_output=True, text=True, env=env, timeout=300)


CASES = [
    ("ubx", ["--column", "bias_s"], "--column does not apply to a receiver recording (UBX/NMEA)"),
    ("ubx", ["--codes", "G C1C"], "--codes does not apply to a receiver recording (UBX/NMEA)"),
    ("csv", ["--codes", "G C1C"], "--codes does not apply to a CSV/text file"),
    ("clk", ["--rate", "1"], "--rate does not apply to a RINEX clock product"),
    ("clk", ["--column", "2"], "--column does not apply to a RINEX clock product"),
]


@pytest.mark.parametrize("kind, option, said", CASES, ids=[f"{k} {o[0]}" for k, o, _ in CASES])
def test_an_option_that_does_not_apply_is_refused_naming_it(inputs, kind, option, said):
    path = inputs[kind]
    batch = runner.invoke(app, ["detect", str(path), *TRAIN, *option])
    assert batch.exit_code == 2 and batch.stdout == ""
    assert batch.stderr == f"error: {path}: {said}: it is for " + batch.stderr.split(": it is for ", 1)[1]
    assert len(batch.stderr.splitlines()) == 1
    if option[0] == "--codes":
        return  # detect - takes no --codes (it reads no RINEX observations)
    piped = _piped(path, [*TRAIN, *option])
    assert piped.returncode == 2 and piped.stderr == batch.stderr.replace(str(path), "<stdin>")


def test_follow_without_json_lines_is_refused(inputs):
    result = runner.invoke(app, ["detect", str(inputs["ubx"]), *TRAIN, "--follow", "2"])
    assert result.exit_code == 2 and "--follow 2: a file still being written is read with --json-lines" in result.stderr


def test_where_they_apply_they_are_used(inputs):
    # --column picks the CSV's column: the other column (a straight line) is not the one tested
    by_name = json.loads(runner.invoke(app, ["detect", str(inputs["csv"]), *TRAIN, "--column", "bias_s", "--json"]).stdout)
    other = runner.invoke(app, ["detect", str(inputs["csv"]), *TRAIN, "--column", "other", "--json"])
    assert by_name["n_epochs"] == 900 and other.exit_code in (0, 1, 3)
    assert json.loads(other.stdout)["noise"] != by_name["noise"]
    # --rate on a UBX recording sets its grid: at 1 Hz the recording's own; at 2 Hz every other slot is a gap
    one = json.loads(runner.invoke(app, ["detect", str(inputs["ubx"]), *TRAIN, "--rate", "1", "--json"]).stdout)
    two = json.loads(runner.invoke(app, ["detect", str(inputs["ubx"]), *TRAIN, "--rate", "2", "--json"]).stdout)
    assert one["interval_s"] == 1.0 and one["n_skipped"] == 0
    assert two["interval_s"] == 0.5 and two["n_epochs"] == 1799 and two["n_skipped"] == 899
