"""Export to Stable32: the file Stable32 reads (comment lines, one value per line, 0 for a gap); read back
the way Stable32 reads it, the GPS 1PPS record gives Stable32's own published ADEV table."""

import gzip
import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from chronofuse.analysis import stability as st
from chronofuse.cli.main import app
from chronofuse.io.records import read_record
from chronofuse.io.stable32 import read_stable32_table
from chronofuse.io.stable32_export import write_stable32

DATA = Path(__file__).parents[1] / "data"
GPS = DATA / "stability" / "gps"


def _stable32_read(path: Path) -> np.ndarray:
    """What Stable32 takes from a data file: the numbers of the lines that are not ``#`` comments."""
    return np.array([float(line) for line in path.read_text().splitlines() if line and not line.startswith("#")])


def test_the_exported_gps_record_gives_stable32s_published_adev(tmp_path):
    phase = np.loadtxt(GPS / "gps_1pps_phase_data.txt.gz", comments="#")
    out = tmp_path / "gps.txt"
    assert write_stable32(out, phase, 1.0, "phase") == 0
    back = _stable32_read(out)
    np.testing.assert_allclose(back, phase, rtol=1e-11, atol=0)
    ref = read_stable32_table(GPS / "stable32_ADEV_decade.txt")
    res = st.compute("adev", back, 1.0, ref["tau"])
    np.testing.assert_allclose(res.dev, ref["dev"], rtol=5e-5)  # Stable32 prints 5 significant digits


def test_gaps_are_written_as_zero_and_read_back_as_gaps(tmp_path):
    values = np.array([1e-9, np.nan, 3e-9, 4e-9, np.nan])
    out = tmp_path / "gaps.txt"
    assert write_stable32(out, values, 0.5, "phase", source="synthetic") == 2
    assert _stable32_read(out).tolist() == [1e-9, 0.0, 3e-9, 4e-9, 0.0]
    rec = read_record(out, rate_hz=0.5, zero_is_gap=True)
    np.testing.assert_array_equal(np.isnan(rec.values), np.isnan(values))
    assert "tau0 = 2 s" in out.read_text()


def test_a_log_with_offsets_of_exactly_zero_is_exported_with_a_warning(tmp_path):
    out = tmp_path / "ts2phc.txt"
    runner = CliRunner()
    result = runner.invoke(app, ["stability", str(DATA / "logs" / "linuxptp" / "ts2phc-short.log.gz"), "--station",
                                 "ens7f1 [", "--dev", "adev", "--export-stable32", str(out)])
    assert result.exit_code == 0, result.output
    assert "exactly 0, which Stable32 reads as gaps" in result.output
    assert _stable32_read(out).size == 13


def test_a_record_without_zeros_is_exported_without_a_warning(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        write_stable32(tmp_path / "x.txt", np.array([1.5e-9, -2e-9]), 1.0, "freq")
