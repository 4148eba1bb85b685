"""`chronofuse stability`: JSON shape, agreement with the library, and one-line errors with exit code 2."""

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.analysis import stability
from chronofuse.cli.main import app
from chronofuse.io.records import read_record

runner = CliRunner()


def invoke(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_json_output_is_one_document_with_the_documented_shape(data_dir):
    path = data_dir / "stability/phasedat/PHASE.DAT"
    result = invoke("stability", path, "--rate", 1, "--dev", "adev,mdev,tdev", "--taus", "octave", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert (doc["n"], doc["rate"], doc["kind"]) == (1001, 1.0, "phase")
    assert set(doc["deviations"]) == {"adev", "mdev", "tdev"}
    for key in ("tau", "dev", "lo", "hi"):
        assert len(doc["deviations"]["adev"][key]) == len(doc["deviations"]["adev"]["tau"])


def test_cli_numbers_equal_the_library_numbers(data_dir):
    path = data_dir / "stability/phasedat/PHASE.DAT"
    doc = json.loads(invoke("stability", path, "--rate", 1, "--dev", "oadev", "--taus", "1,10,100", "--json").stdout)
    lib = stability.oadev(read_record(path, rate_hz=1.0).values, 1.0, np.array([1.0, 10.0, 100.0]))
    np.testing.assert_allclose(doc["deviations"]["oadev"]["dev"], lib.dev, rtol=1e-12)
    np.testing.assert_allclose(doc["deviations"]["oadev"]["tau"], [1, 10, 100])


def test_frequency_records_with_a_mask_and_a_plot(data_dir, tmp_path):
    path = data_dir / "stability/ocxo/ocxo_frequency.txt"
    png = tmp_path / "ocxo.png"
    result = invoke("stability", path, "--kind", "freq", "--rate", 1, "--nominal-hz", 10e6, "--dev", "adev,mtie",
                    "--mask", "prtc-a", "--plot", png, "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["mask"] is not None and isinstance(doc["mask"]["passed"], bool)
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("text", "args", "expected"),
    [
        ("", ("--rate", 1), "bad.txt: no data lines"),
        ("abc\ndef\n", ("--rate", 1), "bad.txt:2: cannot read 'def' as a number"),
        ("0 1e-9\n1 nan\n2 nan\n3 nan\n4 nan\n5 nan\n6 1e-9\n", ("--rate", 1), "bad.txt:2: 5 of 7 samples are missing"),
        ("0 1e-9\n2 2e-9\n1 3e-9\n", ("--rate", 0.5), "bad.txt:3: time is not increasing"),
        ("0 1e-9\n10 2e-9\n20 3e-9\n", ("--rate", 1), "bad.txt:2: rate 1 Hz does not match the time column"),
    ],
)
def test_bad_input_is_a_one_line_error_naming_file_and_line_with_exit_code_2(tmp_path, text, args, expected):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    result = invoke("stability", path, *args, "--json")
    assert result.exit_code == 2
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and expected in lines[0], result.stderr


def test_an_unknown_statistic_or_mask_is_refused_with_exit_code_2(data_dir):
    path = data_dir / "stability/phasedat/PHASE.DAT"
    assert invoke("stability", path, "--rate", 1, "--dev", "adevv").exit_code == 2
    assert invoke("stability", path, "--rate", 1, "--mask", "prtc-z").exit_code == 2


def test_taus_beyond_the_record_are_dropped_with_a_one_line_warning_in_the_json(tmp_path):
    path = tmp_path / "short.txt"
    path.write_text("\n".join(f"{k}e-9" for k in range(12)) + "\n")
    result = invoke("stability", path, "--rate", 1, "--dev", "adev", "--taus", "1,1000", "--json")
    assert result.exit_code == 0 and result.stderr == ""
    doc = json.loads(result.stdout)
    assert doc["deviations"]["adev"]["tau"] == [1.0]
    assert len(doc["warnings"]) == 1 and "tau_s [1000.0] s dropped" in doc["warnings"][0]
