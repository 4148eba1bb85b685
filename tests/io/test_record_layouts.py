"""Records as users bring them: time units and headers, instrument header blocks, date-time stamps,
quoted decimal commas, 0 as a gap. One test per layout, each from a file of that layout: the right
answer, a warning that says what was assumed, or a one-line refusal naming file and line.

Real files: ``stability/keysight53230a/tic_phase.txt.gz``, a Keysight 53230A time-interval export with
its ``#`` header block (allantools' test data, LGPL-3), checked against Stable32's tables of the same
file. No public 53230A/BenchVue CSV export, TimeMonitor export, TimeLab export or Stable32 ``.dat`` with
text header lines was found; those layouts are written here around the real 53230A values (the values
are the instrument's, the layout is rebuilt), so that each answer can be checked against the real file's.
"""

from __future__ import annotations

import gzip
import warnings

import numpy as np
import pytest

from chronofuse.analysis import stability as st
from chronofuse.io.records import read_record
from chronofuse.io.stable32 import read_stable32_table
from chronofuse.validation import InputDataError

KEYSIGHT = "stability/keysight53230a"


@pytest.fixture(scope="module")
def tic(data_dir) -> np.ndarray:
    """The 53230A record's 55,688 phase values (s), as written in its file."""
    with gzip.open(data_dir / KEYSIGHT / "tic_phase.txt.gz", "rt") as fh:
        return np.array([float(v) for v in fh.read().split("\n") if v.strip() and not v.startswith("#")])


def _quietly(**kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return read_record(**kw)


def test_a_53230a_export_takes_its_unit_and_interval_from_its_header_block(data_dir):
    """The file says "# phase data, unit: s" and "# data interval 1 s": no --rate is needed, the record
    says where the interval came from, and its ADEV is Stable32's for the same file."""
    rec = _quietly(path=data_dir / KEYSIGHT / "tic_phase.txt.gz")
    assert rec.values.size == 55_688 and rec.rate_hz == 1.0 and rec.kind == "phase"
    assert any("sample interval 1 s from header line 9" in n for n in rec.notes)
    assert any("values in s, from header line 8" in n for n in rec.notes)
    table = read_stable32_table(data_dir / KEYSIGHT / "tic_oadev.txt")
    dev = st.oadev(rec.values, rec.rate_hz, table["tau"])
    np.testing.assert_allclose(dev.dev, table["dev"], rtol=5e-5)
    np.testing.assert_array_equal(dev.n, table["n"])


def test_mjd_time_tags_without_a_header_are_read_as_days_with_a_warning(tmp_path, tic):
    """The Stable32/TimeLab time-tag layout: read as seconds it was 86399.8 Hz and an ADEV 86400 times
    too large, silently."""
    mjd = 57104.0 + np.arange(2000) / 86400.0
    path = tmp_path / "mjd.dat"
    path.write_text("".join(f"{t:.9f} {v:.14e}\n" for t, v in zip(mjd, tic[:2000])))
    with pytest.warns(UserWarning, match="read as MJD days"):
        rec = read_record(path)
    assert rec.rate_hz == pytest.approx(1.0, rel=1e-9)
    np.testing.assert_allclose(rec.values, tic[:2000])
    named = tmp_path / "mjd_named.txt"
    named.write_text("mjd phase\n" + path.read_text())
    assert _quietly(path=named).rate_hz == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize(
    ("header", "scale", "kind"),
    [("Time (s),Phase (ns)", 1e9, "phase"), ("t,phase[us]", 1e6, "phase"), ("time_s,x_ps", 1e12, "phase"),
     ("Time (s),y_ppb", 1e9, "freq"), ("t;Frequency offset (ppm)", 1e6, "freq")],
)
def test_units_written_in_the_header_scale_the_values_and_set_the_kind(tmp_path, tic, header, scale, kind):
    sep = ";" if ";" in header else ","
    values = tic[:500] if kind == "phase" else np.diff(tic[:501])  # a frequency record in ppb/ppm
    path = tmp_path / "units.csv"
    path.write_text(header + "\n" + "".join(f"{k}{sep}{float(v) * scale!r}\n" for k, v in enumerate(values)))
    rec = _quietly(path=path)
    assert rec.kind == kind and rec.rate_hz == 1.0
    np.testing.assert_allclose(rec.values, values, rtol=1e-12)


@pytest.mark.parametrize(
    ("header", "scale", "kind"),
    [("t,y[1e-12]", 1e12, "freq"), ("t,y (1e-12)", 1e12, "freq"), ("t,y[x1e-15]", 1e15, "freq"),
     ("t,y_ppt", 1e12, "freq"), ("t,x[1e-9]", 1e9, "phase"), ("t,phase (1e-12 s)", 1e12, "phase"),
     ("t,y [×10^-12]", 1e12, "freq")],
)
def test_a_numeric_scale_factor_in_a_header_scales_the_values(tmp_path, tic, header, scale, kind):
    """``y[1e-12]`` and ``y (1e-12)`` were read 1e12 times too large, with only a plausibility warning."""
    values = tic[:500] if kind == "phase" else np.diff(tic[:501])
    path = tmp_path / "factor.csv"
    path.write_text(header + "\n" + "".join(f"{k},{float(v) * scale!r}\n" for k, v in enumerate(values)))
    rec = _quietly(path=path)
    assert rec.kind == kind and rec.rate_hz == 1.0
    np.testing.assert_allclose(rec.values, values, rtol=1e-12)
    assert any(header.split(",")[1] in n for n in rec.notes)


def test_a_unit_that_contradicts_the_kind_asked_for_is_refused(tmp_path):
    path = tmp_path / "y.csv"
    path.write_text("t,y_ppb\n0,1.5\n1,1.6\n2,1.4\n")
    with pytest.raises(InputDataError, match=r"y.csv:1: column .y_ppb. is in ppb.*use kind freq") as info:
        read_record(path, kind="phase")
    assert "\n" not in str(info.value)


def test_frequency_offsets_in_hz_need_the_nominal_frequency_and_are_then_fractional(tmp_path):
    path = tmp_path / "f.csv"
    path.write_text("t,f_offset_Hz\n" + "".join(f"{k},{0.01 * (1 + 0.1 * float(np.sin(k)))!r}\n" for k in range(300)))
    with pytest.raises(InputDataError, match=r"f.csv:1: column 'f_offset_Hz' is in Hz: give the nominal frequency"):
        read_record(path)
    rec = _quietly(path=path, nominal_hz=10e6)
    assert rec.kind == "freq"
    np.testing.assert_allclose(rec.values, 0.01 * (1 + 0.1 * np.sin(np.arange(300))) / 10e6, rtol=1e-12)


def test_epoch_milliseconds_in_a_timestamp_column_are_read_as_milliseconds_with_a_warning(tmp_path, tic):
    """It used to become 0.001 Hz."""
    path = tmp_path / "ms.csv"
    start = 1_700_000_000_000
    path.write_text("timestamp,phase_s\n" + "".join(f"{start + 100 * k},{float(v)!r}\n" for k, v in enumerate(tic[:800])))
    with pytest.warns(UserWarning, match="read as UNIX milliseconds"):
        rec = read_record(path)
    assert rec.rate_hz == pytest.approx(10.0)
    assert rec.t_ns[0] == start * 1_000_000


def test_a_zero_is_a_gap_when_asked_as_in_stable32(tmp_path, tic):
    y = np.diff(tic[:1001]) * 1e9 + 0.25  # frequency in ppb, away from 0 (the counter's steps are often 0)
    y[[10, 500, 501]] = 0.0
    path = tmp_path / "y0.txt"
    path.write_text("".join(f"{float(v)!r}\n" for v in y))
    plain = read_record(path, kind="freq", rate_hz=1.0)
    gaps = read_record(path, kind="freq", rate_hz=1.0, zero_is_gap=True)
    assert plain.n_gaps == 0 and gaps.n_gaps == 3 and np.isnan(gaps.values[[10, 500, 501]]).all()


def test_a_stable32_dat_file_with_text_header_lines_is_read_and_the_lines_noted(tmp_path, tic):
    path = tmp_path / "tic.dat"
    path.write_text("Keysight 53230A TI ch1-ch2\nH-maser reference\nphase data in seconds, tau 1 s\n"
                    + "".join(f"{v:.14e}\n" for v in tic[:1000]))
    rec = _quietly(path=path, rate_hz=1.0)
    np.testing.assert_array_equal(rec.values, tic[:1000])
    assert any("3 header-block lines before the data skipped (lines 1-3)" in n for n in rec.notes)


def test_an_instrument_csv_header_block_before_a_header_line_is_skipped(tmp_path, tic):
    """A 53230A/BenchVue-style CSV: quoted key,value lines, then the column names, then the readings; the
    reading number is no time column, the interval is stated in the block."""
    block = ('"Instrument","Keysight 53230A"\n"Serial","MY50001484"\n"Function","Time Interval 1 to 2"\n'
             '"Sample Interval","1.0E+00"\n\n"Reading #","Value (s)"\n')
    path = tmp_path / "benchvue.csv"
    path.write_text(block + "".join(f"{k + 1},{v:.8E}\n" for k, v in enumerate(tic[:1500])))
    rec = _quietly(path=path)
    assert rec.rate_hz == 1.0 and rec.column == "Value (s)" and rec.t_ns is None
    np.testing.assert_allclose(rec.values, tic[:1500], rtol=1e-8)
    no_interval = tmp_path / "no_interval.csv"
    no_interval.write_text(block.replace('"Sample Interval","1.0E+00"\n', "") +
                           "".join(f"{k + 1},{v:.8E}\n" for k, v in enumerate(tic[:100])))
    with pytest.raises(InputDataError, match="give the sample rate"):
        read_record(no_interval)


def test_a_timemonitor_style_header_block_with_a_stated_interval_is_read(tmp_path, tic):
    block = ("TimeMonitor TIE export\nStart Time: 2015-03-27 10:00:00\nSample Interval: 1.000000E+0 s\n"
             "Units: ns\nTIE\n")
    path = tmp_path / "tm.txt"
    path.write_text(block + "".join(f"{v * 1e9:.4f}\n" for v in tic[:1200]))
    rec = _quietly(path=path)
    assert rec.rate_hz == 1.0
    np.testing.assert_allclose(rec.values, tic[:1200], rtol=1e-6)
    assert any("values in ns, from header line 4" in n for n in rec.notes)


@pytest.mark.parametrize(
    ("stamp", "sep"),
    [("2015-03-27T10:00:{s:02d}.000000000Z", ","), ("2015-03-27 10:00:{s:02d}.5", ","),
     ("2015-03-27 10:00:{s:02d}", " "), ("27.03.2015 10:00:{s:02d}", ";"), ("2015/03/27T10:00:{s:02d}+01:00", ",")],
)
def test_iso_8601_and_date_time_stamps_give_the_time_grid(tmp_path, tic, stamp, sep):
    lines = []
    for k in range(60):
        value = f"{tic[k]:.8e}".replace(".", ",") if sep == ";" else f"{tic[k]:.8e}"
        lines.append(f"{stamp.format(s=k)}{sep}{value}\n")
    lines.insert(10, "")  # a sample missing: the grid keeps its slot
    del lines[10:12]
    path = tmp_path / "iso.txt"
    path.write_text("".join(lines))
    rec = _quietly(path=path)
    assert rec.rate_hz == 1.0 and rec.values.size == 60 and rec.n_gaps == 1 and np.isnan(rec.values[10])
    np.testing.assert_allclose(np.delete(rec.values, 10), np.delete(tic[:60], 10), rtol=1e-8)
    assert np.diff(rec.t_ns).tolist() == [1_000_000_000] * 59


def test_a_date_whose_day_and_month_order_cannot_be_told_is_refused(tmp_path):
    path = tmp_path / "us.csv"
    path.write_text("03/04/2015 10:00:00,1e-9\n03/04/2015 10:00:01,2e-9\n03/04/2015 10:00:02,3e-9\n")
    with pytest.raises(InputDataError, match=r"us.csv:1: '03/04/2015 10:00:00': day and month order"):
        read_record(path)


def test_stamps_with_and_without_a_time_zone_mixed_are_refused(tmp_path):
    path = tmp_path / "mixed.csv"
    path.write_text("2015-03-27T10:00:00Z,1e-9\n2015-03-27T10:00:01,2e-9\n2015-03-27T10:00:02Z,3e-9\n")
    with pytest.raises(InputDataError, match=r"mixed.csv:2: time stamp '2015-03-27T10:00:01' has no time zone"):
        read_record(path)


def test_quoted_decimal_comma_csv_is_read(tmp_path, tic):
    path = tmp_path / "quoted.csv"
    path.write_text('"t";"x"\n' if False else '"t","x (ns)"\n' + "".join(
        f'"{k}","{v * 1e9:.5f}"\n'.replace(".", ",") for k, v in enumerate(tic[:300])))
    rec = _quietly(path=path)
    np.testing.assert_allclose(rec.values, tic[:300], rtol=1e-6)
    assert rec.rate_hz == 1.0


def test_phase_in_ns_without_a_unit_is_analysed_with_a_warning(tmp_path, tic):
    path = tmp_path / "ns.txt"
    path.write_text("".join(f"{v * 1e9:.4f}\n" for v in tic[:500]))
    with pytest.warns(UserWarning, match="implausible for a clock; if the values are in ns or ps"):
        rec = read_record(path, rate_hz=1.0)
    np.testing.assert_allclose(rec.values, tic[:500] * 1e9, rtol=1e-6)


def test_the_samples_rule_equals_allantools_gap_robust_adev_on_its_own_gap_file(data_dir):
    """allantools' gradev test file (a 240-sample NaN run in white phase): OADEV under the "samples" rule
    is allantools.gradev, value and term count."""
    import allantools

    x = read_record(data_dir / "stability/gradev_y_gap.dat.gz", rate_hz=1.0, max_gap_fraction=0.9).values
    taus = np.array([1.0, 2.0, 4.0, 16.0, 64.0])
    ours = st.oadev(x, 1.0, taus)
    _, dev, _, n = allantools.gradev(x, rate=1.0, data_type="phase", taus=taus)
    np.testing.assert_allclose(ours.dev, dev, rtol=1e-12)
    np.testing.assert_array_equal(ours.n, n)


@pytest.mark.parametrize(
    ("stamp", "sep"),
    [("2023-03-26T00:00:{s:02d},000Z", ";"), ("2023-03-26 00:00:{s:02d} UTC", ","),
     ("2023-03-26T00:00:{s:02d},250 UTC", ";")],
)
def test_iso_stamps_with_a_comma_fraction_or_the_word_utc_are_read(tmp_path, tic, stamp, sep):
    """Both were refused as "no data lines", naming no line."""
    path = tmp_path / "stamps.csv"
    path.write_text(f"time{sep}phase\n" + "".join(f"{stamp.format(s=k)}{sep}{float(v)!r}\n"
                                                   for k, v in enumerate(tic[:60])))
    rec = _quietly(path=path)
    assert rec.rate_hz == 1.0 and rec.values.size == 60
    np.testing.assert_array_equal(rec.values, tic[:60])
    start = np.datetime64("2023-03-26T00:00:00", "ns").astype(np.int64)
    assert rec.t_ns[0] == start + (250_000_000 if ",250" in stamp else 0)


def test_fortran_d_exponents_are_read_as_e(tmp_path, tic):
    path = tmp_path / "d.txt"
    path.write_text("".join(f"{float(v):.15E}\n".replace("E", "D") for v in tic[:300]))
    rec = _quietly(path=path, rate_hz=1.0)
    np.testing.assert_array_equal(rec.values, np.array([float(f"{float(v):.15E}") for v in tic[:300]]))
    two = tmp_path / "d2.txt"
    two.write_text("".join(f"{k} {float(v):.15e}\n".replace("e", "d") for k, v in enumerate(tic[:300])))
    assert _quietly(path=two).values[5] == float(f"{float(tic[5]):.15e}")


def test_a_file_with_no_line_of_data_names_the_first_line_that_could_be_and_why(tmp_path):
    path = tmp_path / "odd.log"
    path.write_text("# a comment\nsome text\n1.5 apples\n2.5 apples\n")
    with pytest.raises(InputDataError, match=r"odd.log:3: .*'1.5 apples'.*'apples' is no number") as info:
        read_record(path, rate_hz=1.0)
    assert "\n" not in str(info.value) and "no data lines" not in str(info.value)


def test_a_header_unit_line_gives_the_values_unit_and_the_time_unit_clause_by_clause(tmp_path, tic):
    """``# phase units: ns, time units: s`` was read as values in seconds (the last clause), 1e9 off."""
    values = tic[:500]
    path = tmp_path / "clauses.csv"
    path.write_text("# phase units: ns, time units: min\nt,value\n"
                    + "".join(f"{k},{float(v) * 1e9!r}\n" for k, v in enumerate(values)))
    rec = _quietly(path=path)
    np.testing.assert_allclose(rec.values, values, rtol=1e-12)
    assert rec.rate_hz == pytest.approx(1.0 / 60.0)


@pytest.mark.parametrize(("header", "interval_s"), [("Time (min),Phase (ns)", 60.0), ("time_h,phase_ns", 3600.0),
                                                    ("t[ms],x[ns]", 1e-3)])
def test_time_columns_in_minutes_hours_or_milliseconds_give_their_interval(tmp_path, tic, header, interval_s):
    """``Time (min)`` was read as seconds: a 60 s record at 1 Hz, ADEV 7x off at 60 s."""
    values = tic[:200]
    path = tmp_path / "minutes.csv"
    path.write_text(header + "\n" + "".join(f"{k},{float(v) * 1e9!r}\n" for k, v in enumerate(values)))
    rec = _quietly(path=path)
    assert rec.rate_hz == pytest.approx(1.0 / interval_s)
    np.testing.assert_allclose(rec.values, values, rtol=1e-12)


def test_a_time_column_in_a_unit_word_the_reader_does_not_know_is_warned_not_taken_as_seconds(tmp_path, tic):
    path = tmp_path / "fortnights.csv"
    path.write_text("time (fortnights),phase (ns)\n" + "".join(f"{k},{float(v) * 1e9!r}\n"
                                                              for k, v in enumerate(tic[:200])))
    with pytest.warns(Warning, match="fortnights"):
        read_record(path=path)
