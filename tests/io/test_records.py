"""Reading phase/frequency records: real files, and every kind of bad input named by file and line."""

import bz2
import gzip
import lzma
import warnings
import zipfile
from fractions import Fraction

import numpy as np
import pyarrow as pa
import pytest

from chronofuse.io.columns import decimal_text_to_ns, read_columns, sniff
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
    with pytest.raises(InputDataError, match="ocxo_frequency.txt:.*nominal_hz"):
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
        ("alpha\nbeta\ngamma\n", "no data lines .*only comments and text lines; the first, 'alpha'", 1),
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


def test_a_rate_that_disagrees_with_the_time_column_overrides_it_with_a_warning(tmp_path):
    path = tmp_path / "rate.txt"
    path.write_text("0 1e-9\n10 2e-9\n20 3e-9\n")
    with pytest.warns(UserWarning, match=r"rate.txt: rate_hz 1 Hz overrides the time column \(median step 10 s"):
        rec = read_record(path, rate_hz=1.0)
    assert rec.rate_hz == 1.0 and rec.values.size == 3 and rec.n_gaps == 0


def test_one_column_without_a_rate_asks_for_it(tmp_path):
    path = tmp_path / "x.txt"
    path.write_text("1e-9\n2e-9\n")
    with pytest.raises(InputDataError, match="give the sample rate .rate_hz"):
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
    assert rec.t_ns[0] == 60000 * 86_400 * 10**9 and rec.t_s[-1] == 3 * 86_400.0


def test_a_column_number_picks_the_column_even_with_a_header(tmp_path):
    path = tmp_path / "te.csv"
    path.write_text("t_s,a_ns,b_ns\n0,1,10\n1,2,20\n2,3,30\n")
    rec = read_record(path, column="3")
    np.testing.assert_allclose(rec.values, [10e-9, 20e-9, 30e-9])
    with pytest.raises(InputDataError, match=r"column '4' not found"):
        read_record(path, column="4")


# --- Layouts met in practice, and the cases a new user hit ---------------------------------


def test_a_utf8_bom_does_not_turn_the_first_sample_into_a_header(tmp_path):
    path = tmp_path / "bom.txt"
    path.write_bytes("\ufeff1.5e-9\n2.5e-9\n3.5e-9\n4.5e-9\n5.5e-9\n6.5e-9\n".encode("utf-8"))
    rec = read_record(path, rate_hz=1.0)
    assert rec.values.size == 6
    np.testing.assert_allclose(rec.values[:2], [1.5e-9, 2.5e-9])


def test_a_bom_before_a_header_is_stripped_from_the_first_name(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("\ufefft_s,te_ns\n0,1\n1,2\n2,3\n".encode("utf-8"))
    rec = read_record(path)
    assert rec.rate_hz == 1.0 and rec.column == "te_ns"
    np.testing.assert_allclose(rec.values, [1e-9, 2e-9, 3e-9])


def test_a_one_column_file_with_decimal_commas_is_refused_naming_the_line(tmp_path):
    path = tmp_path / "comma.txt"
    path.write_text("1,475\n1,482\n1,470\n1,491\n")
    with pytest.raises(InputDataError, match=r"decimal comma") as info:
        read_record(path, rate_hz=1.0)
    assert info.value.line == 2 and info.value.source == str(path)
    path.write_text("0,475\n1,05\n2,470\n")  # an increasing first field, but '05' is a decimal fraction
    with pytest.raises(InputDataError, match=r"'1,05' looks like a number with a decimal comma"):
        read_record(path, rate_hz=1.0)


@pytest.mark.parametrize("sep", [";", "\t", " "])
def test_decimal_commas_between_other_separators_are_read(tmp_path, sep):
    path = tmp_path / "eu.csv"
    path.write_text("".join(f"{k}{sep}{k},5e-9\n" for k in range(5)))
    rec = read_record(path)
    np.testing.assert_array_equal(rec.values, [float(f"{k}.5e-9") for k in range(5)])
    assert rec.rate_hz == 1.0


@pytest.mark.parametrize(("opener", "name"), [(gzip.compress, "record.txt"), (bz2.compress, "record.dat"),
                                              (lzma.compress, "record.gz")])
def test_compression_is_told_by_content_not_by_suffix(tmp_path, opener, name):
    path = tmp_path / name
    path.write_bytes(opener(b"# comment\n" + b"".join(f"{k}e-9\n".encode() for k in range(100))))
    rec = read_record(path, rate_hz=1.0)
    assert rec.values.size == 100 and rec.values[7] == 7e-9


def test_a_zip_archive_is_refused_with_a_message_that_says_so(tmp_path):
    path = tmp_path / "record.txt"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("inner.txt", "1e-9\n2e-9\n")
    with pytest.raises(InputDataError, match="zip archive: extract the record first"):
        read_record(path, rate_hz=1.0)


def test_stable32_dat_layout_indented_numbers_without_a_header(tmp_path):
    path = tmp_path / "PHASE2.DAT"
    text = [f"{v: .10e}" for v in np.arange(20) * 1e-9]
    path.write_text("".join(f"   {v}\n" for v in text))
    rec = read_record(path, rate_hz=1.0)
    np.testing.assert_array_equal(rec.values, [float(v) for v in text])


def test_timelab_export_layout_with_semicolon_comment_lines(tmp_path):
    path = tmp_path / "timelab.txt"
    path.write_text("; TimeLab phase export\n; Trace: A\n; Duration: 20 s\n" + "".join(f"{v:.6e}\n" for v in range(20)))
    rec = read_record(path, rate_hz=1.0)
    assert rec.values.size == 20 and rec.values[-1] == 19.0


def test_53230a_counter_log_layout_with_crlf_and_signed_exponents(tmp_path):
    path = tmp_path / "53230A.txt"
    body = "".join(f"{v:+.6E}\r\n" for v in 2.7e-7 + np.arange(30) * 1e-12)
    path.write_bytes(("# counter: Agilent 53230A\r\n# phase in seconds.\r\n" + body).encode())
    rec = read_record(path, rate_hz=1.0)
    assert rec.values.size == 30
    assert rec.values[3] == pytest.approx(2.70003e-7, rel=1e-12)


def test_comment_lines_and_inline_comments_among_the_data_are_skipped(tmp_path):
    path = tmp_path / "mixed.txt"
    path.write_text("0 1e-9\n# a note\n1 2e-9  # inline\n\n2 3e-9\n")
    rec = read_record(path)
    np.testing.assert_allclose(rec.values, [1e-9, 2e-9, 3e-9])


def test_pyarrow_pandas_and_the_line_reader_give_identical_values(tmp_path):
    """The same numbers through the three readers: pyarrow (plain column), pandas' C parser (a '#' line
    among the data) and the Python line reader (';' columns with a '#' line among the data)."""
    rng = np.random.default_rng(3)
    y = rng.standard_normal(5000) * 1e-9
    fast = tmp_path / "fast.txt"
    fast.write_text("".join(f"{v!r}\n" for v in y.tolist()))
    mid = tmp_path / "mid.txt"
    mid.write_text("# start\n" + "".join(f"{v!r}\n" + ("# mid\n" if k == 2500 else "") for k, v in enumerate(y.tolist())))
    semi = tmp_path / "semi.txt"
    semi.write_text("".join(f"{k};{v!r}\n" + ("# mid\n" if k == 2500 else "") for k, v in enumerate(y.tolist())))
    layout = sniff(semi)
    assert read_columns(semi, layout, 1, None)[2] is False  # the line reader was needed
    for path in (fast, mid, semi):
        np.testing.assert_array_equal(read_record(path, rate_hz=1.0).values, y)


# --- time-tagged data ----------------------------------------------------------------------------


def test_a_10_hz_record_with_unix_epochs_written_by_float_repr_is_read_at_10_hz(tmp_path):
    t0 = 1_700_000_000
    t = t0 + np.arange(600) / 10.0  # float64 repr: 1700000000.1000001 style
    path = tmp_path / "unix.csv"
    path.write_text("time,x_ns\n" + "".join(f"{tk!r},{k}\n" for k, tk in enumerate(t.tolist())))
    rec = read_record(path)
    assert rec.rate_hz == 10.0 and rec.values.size == 600 and rec.n_gaps == 0
    assert rec.t_ns[0] == t0 * 10**9 and rec.t_ns[-1] == t0 * 10**9 + 599 * 10**8
    assert rec.jitter_max_s < 1e-6


def test_an_mjd_column_at_300_s_with_9_decimals_is_read_exactly(tmp_path):
    mjd = [Fraction(60000) + Fraction(300 * k, 86_400) for k in range(200)]
    path = tmp_path / "mjd.txt"
    path.write_text("mjd phase_s\n" + "".join(f"{float(d):.9f} {k}e-9\n" for k, d in enumerate(mjd)))
    rec = read_record(path)
    assert rec.rate_hz == pytest.approx(1 / 300, rel=1e-15) and rec.n_gaps == 0
    # 9 decimals of a day round by up to 43.2 us: that is the jitter reported, and no sample moves.
    assert 0 < rec.jitter_max_s <= 43.2e-6
    assert abs(rec.t_ns[0] - 60000 * 86_400 * 10**9) <= 43_200


def test_decimal_time_text_converts_to_integer_ns_exactly():
    for unit_ns, texts in ((86_400 * 10**9, ["60000.123456789", "60000.0034722222222", "-0.5", "12", ".25", "6e4"]),
                           (10**9, ["1700000000.1000001", " 7.000000000001 ", "+3", "1.7e9", "-1.5"])):
        ns, bad = decimal_text_to_ns(pa.array(texts), unit_ns)
        assert bad == -1
        assert ns.tolist() == [round(Fraction(s.strip()) * unit_ns) for s in texts]
    assert decimal_text_to_ns(pa.array(["1.0", "12:00"]), 10**9)[1] == 1


def test_one_ms_jitter_on_1_s_timestamps_is_accepted_and_reported(tmp_path):
    rng = np.random.default_rng(1)
    n = 20_000
    t = 1e6 + np.arange(n) + rng.uniform(-1e-3, 1e-3, n)
    keep = np.ones(n, bool)
    keep[[100, 101, 5000]] = False  # three missing epochs
    path = tmp_path / "jitter.txt"
    path.write_text("".join(f"{tk:.6f} {k}e-9\n" for k, tk in zip(np.flatnonzero(keep), t[keep])))
    rec = read_record(path)
    assert rec.rate_hz == 1.0 and rec.values.size == n and rec.n_gaps == 3
    assert np.isnan(rec.values[[100, 101, 5000]]).all()
    assert rec.jitter_rms_s == pytest.approx(1e-3 / np.sqrt(3), rel=0.05)  # uniform +-1 ms
    assert rec.jitter_max_s <= 1.01e-3
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_record(path, rate_hz=1.0).values.size == n  # --rate agrees: no warning
    with pytest.warns(UserWarning, match="overrides the time column"):
        assert read_record(path, rate_hz=2.0).values.size == n - 3  # consecutive samples at --rate


# --- frequency magnitude ---------------------------------------------------------------------------


def _nist_1000_point_frequency() -> np.ndarray:
    """NIST SP 1065 section 12.1 (p. 107): n_{i+1} = 16807 n_i mod 2147483647, n_0 = 1234567890, / 2**31-1."""
    n = [1234567890]
    for _ in range(999):
        n.append((16807 * n[-1]) % 2147483647)
    return np.array(n) / 2147483647.0


def test_fractional_frequency_in_0_1_is_analysed_with_a_warning_not_refused(tmp_path):
    path = tmp_path / "nist1000.txt"
    y = _nist_1000_point_frequency()
    path.write_text("".join(f"{v!r}\n" for v in y.tolist()))
    with pytest.warns(UserWarning, match="implausible for a clock"):
        rec = read_record(path, kind="freq", rate_hz=1.0)
    np.testing.assert_array_equal(rec.values, y)
