"""``--quiet``: nothing but errors (and the ``--json`` document) on any stream."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from chronofuse.cli.main import app
from conftest import real_data_dir

runner = CliRunner()
PHASE = real_data_dir() / "stability" / "phasedat" / "PHASE.DAT"


def test_quiet_prints_nothing_where_the_same_command_prints_its_tables(tmp_path):
    args = ["simulate", "oscillator", "--duration", "600", "--out", str(tmp_path / "o.csv")]
    loud = runner.invoke(app, args)
    quiet = runner.invoke(app, [*args, "--quiet"])
    assert loud.exit_code == quiet.exit_code == 0
    assert loud.stdout.strip() and quiet.stdout == "" and quiet.stderr == ""
    assert (tmp_path / "o.csv").read_bytes()  # the work is still done


def test_quiet_with_json_prints_the_document_and_nothing_else():
    result = runner.invoke(app, ["stability", str(PHASE), "--rate", "1", "--dev", "adev", "--json", "--quiet"])
    assert result.exit_code == 0 and result.stderr == ""
    assert json.loads(result.stdout)["deviations"]["adev"]["dev"]


def test_quiet_keeps_errors_and_the_next_command_is_loud_again(tmp_path):
    bad = runner.invoke(app, ["stability", str(PHASE), "--dev", "nope", "--quiet"])
    assert bad.exit_code == 2 and bad.stderr.startswith("error: --dev")
    loud = runner.invoke(app, ["stability", str(PHASE), "--rate", "1", "--dev", "adev"])
    assert loud.exit_code == 0 and "ADEV" in loud.stdout
