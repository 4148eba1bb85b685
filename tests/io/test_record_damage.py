"""Damaged text records are never misread silently: a Windows NaN spelling is a gap, a '#' inside a field is
an error naming the line, an empty line keeps the samples after it in place, and a last line cut short or a
gross outlier is warned. The oracle is the file as written (the values put in it)."""

import warnings

import numpy as np
import pytest

from chronofuse.io.records import read_record
from chronofuse.validation import InputDataError, InputWarning


def _write(tmp_path, name, lines, end="\n"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + end)
    return path


def _read(path, **kw):
    kw.setdefault("rate_hz", 1.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        record = read_record(path, **kw)
    return record, [str(w.message) for w in caught if issubclass(w.category, InputWarning)]


VALUES = [f"{v:.15e}" for v in 1e-9 * np.cos(np.arange(40) * 0.7)]


@pytest.mark.parametrize("spelling", ["1.#QNAN", "-1.#IND", "1.#SNAN", "-1.#QNAN0"])
def test_a_windows_nan_spelling_is_a_gap_not_the_number_before_the_hash(tmp_path, spelling):
    lines = VALUES[:10] + [spelling] + VALUES[10:]
    record, said = _read(_write(tmp_path, "w.txt", lines))
    assert record.values.size == 41 and np.isnan(record.values[10]) and record.n_gaps == 1
    np.testing.assert_array_equal(record.values[11:], np.array(VALUES[10:], dtype=float))
    assert any("Windows NaN" in s and "line 11" in s for s in said)


def test_a_hash_inside_a_field_is_an_error_naming_the_line_and_a_comment_after_a_space_is_not(tmp_path):
    with pytest.raises(InputDataError, match=r":4: '1\.#5': a '#' inside a field"):
        read_record(_write(tmp_path, "bad.txt", VALUES[:3] + ["1.#5"] + VALUES[3:]), rate_hz=1.0)
    late = VALUES * 60 + ["2e-9x#"]  # beyond the sniffed lines too
    with pytest.raises(InputDataError, match="inside a field"):
        read_record(_write(tmp_path, "late.txt", late), rate_hz=1.0)
    record, said = _read(_write(tmp_path, "ok.txt", VALUES[:3] + [VALUES[3] + " # a note"] + VALUES[4:]))
    np.testing.assert_array_equal(record.values, np.array(VALUES, dtype=float))
    assert said == []


def test_an_empty_line_in_a_one_column_file_is_a_gap_that_keeps_the_later_samples_in_place(tmp_path):
    lines = VALUES[:20] + [""] + VALUES[20:] + ["", ""]  # the empty lines at the end are no gap
    record, said = _read(_write(tmp_path, "b.txt", lines))
    assert record.values.size == 41 and np.isnan(record.values[20])
    np.testing.assert_array_equal(record.values[21:], np.array(VALUES[20:], dtype=float))
    assert any("1 empty line among the data (the first at line 21)" in s for s in said)
    spaces = VALUES[:5] + ["   "] + VALUES[5:]
    assert np.isnan(_read(_write(tmp_path, "s.txt", spaces))[0].values[5])


def test_a_last_line_cut_short_and_a_gross_outlier_are_warned(tmp_path):
    cut = VALUES + ["-2.6950708"]
    record, said = _read(_write(tmp_path, "cut.txt", cut))
    assert record.values[-1] == -2.6950708  # read as it stands, but said
    assert any("the last line ('-2.6950708') looks cut short (8 digits where the lines before have 16)" in s
               for s in said)
    assert any("1 gross outlier" in s and "line 41" in s for s in said)
    unended = _read(_write(tmp_path, "u.txt", VALUES[:-1] + [VALUES[-1][:12]], end=""))[1]
    assert any("no line end" in s for s in unended)
    # an outlier in the middle, and a phase step that is none
    middle = VALUES[:10] + ["3.2"] + VALUES[10:]
    assert any("1 gross outlier (a value 3.2 at line 11" in s for s in _read(_write(tmp_path, "m.txt", middle))[1])
    step = [f"{v:.15e}" for v in np.r_[1e-9 * np.cos(np.arange(20.0)), 1.0 + 1e-9 * np.cos(np.arange(20.0))]]
    assert _read(_write(tmp_path, "step.txt", step))[1] == []
    # a clean file: nothing said
    assert _read(_write(tmp_path, "clean.txt", VALUES))[1] == []


def test_a_delimiter_at_the_end_of_every_line_is_an_empty_field_not_a_decimal_comma(tmp_path):
    lines = ["t,phase_s,"] + [f"{k},{v}," for k, v in enumerate(VALUES)]
    record, said = _read(_write(tmp_path, "tc.csv", lines))
    np.testing.assert_array_equal(record.values, np.array(VALUES, dtype=float))
    assert said == [] and record.rate_hz == 1.0


@pytest.mark.parametrize("decimals, resolution", [(5, 0.864), (6, 0.0864)])
def test_mjd_tags_quantised_near_the_step_are_snapped_to_it_not_read_with_invented_gaps(tmp_path, decimals,
                                                                                        resolution):
    # 1 s samples tagged in MJD days rounded to 5 (6) decimals: 1e-5 day = 0.864 s, steps of 0.864 and 1.728 s
    tags = [f"{60000 + k / 86400:.{decimals}f}" for k in range(600)]
    values = [f"{v:.6e}" for v in 1e-9 * np.cos(np.arange(600) * 0.3)]
    path = _write(tmp_path, "mjd.txt", [f"{t} {v}" for t, v in zip(tags, values)])
    record, said = _read(path, rate_hz=None)
    assert record.rate_hz == 1.0 and record.n_gaps == 0 and record.values.size == 600
    np.testing.assert_array_equal(record.values, np.array(values, dtype=float))
    assert any(f"resolution of {resolution:g} s" in s and "read on a 1 s grid" in s for s in said)
    assert record.jitter_max_s <= resolution  # the rounding, measured from the grid's mean phase


def test_a_complete_short_last_line_is_a_value_not_a_truncation(tmp_path):
    """``99999.0,0`` or ``99999.0,1e-9`` after ``%.15e`` lines, with a line end, are values: nothing said;
    one cut before its exponent is warned."""
    lines = ["t,x"] + [f"{k}.0,{v}" for k, v in enumerate(VALUES)]
    for last in ("40.0,0", "40.0,1e-9"):
        record, said = _read(_write(tmp_path, "ok.csv", lines + [last]))
        assert not any("cut short" in s for s in said) and record.values[-1] == float(last.split(",")[1])
    assert any("cut short" in s for s in _read(_write(tmp_path, "f.csv", lines + ["40.0,-2.69507"]))[1])
