"""Stable32's result tables read as published: columns, the rows Stable32 comments out, and bad tables named."""

import numpy as np
import pytest

from chronofuse.io.stable32 import read_stable32_table
from chronofuse.validation import InputDataError


def test_the_oadev_table_of_phase_dat_has_the_term_counts_of_sp1065(real_data):
    # PHASE.DAT holds N = 1001 phase points (the table's header says so); overlapping ADEV at factor m
    # averages N - 2m second differences (NIST SP 1065 eq. 11).
    table = read_stable32_table(real_data / "stability/phasedat/phase_dat_oadev_octave.txt")
    assert set(table) == {"af", "tau", "n", "alpha", "lo", "dev", "hi"}
    np.testing.assert_array_equal(table["af"], 2 ** np.arange(table["af"].size))
    np.testing.assert_array_equal(table["tau"], table["af"] * 1.0)
    np.testing.assert_array_equal(table["n"], 1001 - 2 * table["af"])
    assert (table["lo"] <= table["dev"]).all() and (table["dev"] <= table["hi"]).all()
    assert table["n"].dtype == table["af"].dtype == table["alpha"].dtype == np.int64


def test_rows_stable32_comments_out_are_skipped(real_data):
    # In this MTOTDEV table Stable32 commented out the rows from AF 32 on (too few terms to trust).
    table = read_stable32_table(real_data / "stability/phasedat/phase_dat_mtotdev_octave.txt")
    assert table["af"].tolist() == [1, 2, 4, 8, 16]


def test_a_four_column_mtie_table_gives_its_values_without_a_confidence_interval(real_data):
    table = read_stable32_table(real_data / "stability/Cs5071A/mtie_decade.txt")
    assert set(table) == {"af", "tau", "n", "dev"}
    assert table["dev"][0] == 1.9662e-08  # the first row as printed
    assert (np.diff(table["dev"]) >= 0).all()  # MTIE never decreases with tau (a longer window holds the shorter)


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("# only a header\n", "no table rows"),
        ("1 1.0 10 1e-9 2e-9\n", "5 columns"),
        ("1 1.0 10 1e-9\n2 2.0 9\n", "t.txt:2: 3 columns on this row"),
        ("1 1.0 10 1e-9\n2 2.0 9 x\n", "t.txt:2: cannot read row"),
    ],
)
def test_a_table_that_is_not_a_stable32_table_is_refused_naming_the_file_and_line(tmp_path, text, fragment):
    path = tmp_path / "t.txt"
    path.write_text(text)
    with pytest.raises(InputDataError, match=fragment):
        read_stable32_table(path)
