"""Reading phase/frequency records: real files, and every kind of bad input named by file and line."""

import gzip

import numpy as np
import pytest

from chronofuse.io.records import read_record
from chronofuse.validation import InputDataError


def test_stable32_phase_file_reads_all_1001_points(data_dir):
    rec = read_record(data_dir / "stability/phasedat/PHASE.DAT", rate_hz=1.0)
    assert rec.values.size == 1001
    assert rec.values[1] == pytest.approx(8.511601033439709e-02, rel=1e-15)
    assert rec.n_gaps == 0 and rec.t_s is None


def test_gzipped_gps_record_reads_with_its_comment_lines(data_dir):
    rec = read_record(data_dir / "stability/gps/gps_1pps_phase_data.txt.gz", rate_hz=1.0)
    assert rec.values.size == 241_218


def test_absolute_frequency_in_hz_is_rejected_without_the_nominal_frequency(data_dir):
    path = data_dir / "stability/ocxo/ocxo_frequency.txt"
    with pytest.raises(InputDataError, match="ocxo_frequency.txt:.*--nominal-hz"):
        read_record(path, kind="freq", rate_hz=1.0)
    rec = read_record(path, kind="freq", rate_hz=1.0, nominal_hz=10e6)
    assert np.nanmax(np.abs(rec.values)) < 1e-7


def test_two_columns_with_header_give_time_rate_and_unit_scaling(tmp_path):
    path = tmp_path / "te.csv"
    path.write_text("t_s,te_ns\n0,1.5\n10,2.5\n20,3.5\n")
    rec = read_record(path)
    assert rec.rate_hz == pytest.approx(0.1)
    np.testing.assert_allclose(rec.values, [1.5e-9, 2.5e-9, 3.5e-9])


def test_a_time_gap_of_whole_intervals_becomes_missing_samples(tmp_path):
    path = tmp_path / "gap.txt"
    path.write_text("0 1e-9\n1 2e-9\n4 5e-9\n5 6e-9\n")
    rec = read_record(path, rate_hz=1.0)
    assert rec.values.size == 6 and rec.n_gaps == 2
    assert np.isnan(rec.values[2:4]).all()


@pytest.mark.parametrize(
    ("text", "message", "line"),
    [
        ("", "no data lines", None),
        ("# only a comment\n", "no data lines", None),
        ("alpha\nbeta\ngamma\n", "cannot read 'beta' as a number", 2),
        ("1e-9\n2e-9\nabc\n", "cannot read 'abc' as a number", 3),
        ("0 1e-9\n1 2e-9\n1 3e-9\n", "time is not increasing", 3),
        ("0 1e-9\n2 2e-9\n1 3e-9\n", "time is not increasing", 3),
        ("0 1e-9\n1 2e-9 5\n", "3 values on this line, expected 2", 2),
        ("nan\nnan\nnan\n1e-9\n", "3 of 4 samples are missing .*the longest, 3 samples", 1),
        ("1e-9\nnan\n2e-9\nnan\nnan\nnan\n", "4 of 6 samples are missing .*the longest, 3 samples", 4),
        ("0 1e-9\n1 2e-9\n9 3e-9\n", "7 of 10 samples are missing .*the longest, 7 samples", 2),
        ("0 1e-9\n1 2e-9\n2.5 3e-9\n", "not a whole number", 3),
    ],
)
def test_bad_input_raises_one_error_naming_the_file_and_line(tmp_path, text, message, line):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(InputDataError, match=message) as info:
        read_record(path, rate_hz=1.0)
    assert info.value.source == str(path)
    assert info.value.line == line
    assert "\n" not in str(info.value)


def test_a_rate_that_does_not_match_the_time_column_is_an_error(tmp_path):
    path = tmp_path / "rate.txt"
    path.write_text("0 1e-9\n10 2e-9\n20 3e-9\n")
    with pytest.raises(InputDataError, match=r"rate 1 Hz does not match the time column \(interval 10 s"):
        read_record(path, rate_hz=1.0)


def test_one_column_without_a_rate_asks_for_it(tmp_path):
    path = tmp_path / "x.txt"
    path.write_text("1e-9\n2e-9\n")
    with pytest.raises(InputDataError, match="--rate"):
        read_record(path)


def test_a_corrupt_gzip_file_is_named(tmp_path):
    path = tmp_path / "x.txt.gz"
    path.write_bytes(gzip.compress(b"1e-9\n2e-9\n" * 100)[:30])
    with pytest.raises(InputDataError, match="x.txt.gz"):
        read_record(path, rate_hz=1.0)


def test_missing_file_and_directory_are_named(tmp_path):
    with pytest.raises(InputDataError, match="no such file"):
        read_record(tmp_path / "nope.txt", rate_hz=1.0)
    with pytest.raises(InputDataError, match="is a directory"):
        read_record(tmp_path, rate_hz=1.0)


def test_an_mjd_time_column_is_read_in_days(tmp_path):
    path = tmp_path / "daily.txt"
    path.write_text("mjd value\n60000 1e-9\n60001 2e-9\n60003 4e-9\n")
    rec = read_record(path)
    assert rec.rate_hz == pytest.approx(1 / 86_400)
    assert rec.values.size == 4 and rec.n_gaps == 1
    assert rec.t_s[0] == pytest.approx(60000 * 86_400.0)


def test_a_column_number_picks_the_column_even_with_a_header(tmp_path):
    path = tmp_path / "te.csv"
    path.write_text("t_s,a_ns,b_ns\n0,1,10\n1,2,20\n2,3,30\n")
    rec = read_record(path, column="3")
    np.testing.assert_allclose(rec.values, [10e-9, 20e-9, 30e-9])
    with pytest.raises(InputDataError, match=r"column '4' not found"):
        read_record(path, column="4")
