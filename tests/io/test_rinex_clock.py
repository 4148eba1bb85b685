"""RINEX clock products: the AR (station clock) records of the IGS, CODE and GRG files."""

import gzip

import numpy as np
import pytest

from chronofuse.io.formats import sniff_format
from chronofuse.io.rinex_clock import read_station_clocks, station_clock_bias
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError


def _ar_lines(path, station):
    with gzip.open(path, "rt") as fh:
        text = fh.read().split("END OF HEADER", 1)[1]
    return [line.split() for line in text.splitlines() if line.startswith(f"AR {station} ")]


def test_every_ar_record_of_the_igs_file_is_read_against_a_plain_split_of_its_lines(real_data):
    path = real_data / "receivers/rinex/rtklib/igs15904.clk.gz"
    assert sniff_format(path) == "rinex-clock"
    clocks = read_station_clocks(path)
    assert len(clocks.stations) == 176 and clocks.n_bad_lines == 0  # the header's "# OF SOLN STA" minus 4 absent
    for station in ("MANA", "TIXJ", "ALGO"):
        rows = _ar_lines(path, station)
        np.testing.assert_array_equal(clocks.bias_s[station], [float(r[9]) for r in rows])
        assert np.all(np.diff(clocks.gps_ns[station]) == 300 * NS_PER_S)
    # 2010-07-01 00:00 GPS time is GPS week 1590, day 4 (the header's comment)
    assert clocks.gps_ns["MANA"][0] == (1590 * 7 + 4) * 86400 * NS_PER_S


def test_a_long_gap_becomes_missing_epochs_and_the_station_stays_usable(real_data):
    # the GRG file's 1 h 45 min gap made the whole file unusable
    clocks = read_station_clocks(real_data / "receivers/rinex/gnss_lib_py/grg21553.clk.gz")
    data = station_clock_bias(clocks, "TLSE")
    assert data.interval_s == 30.0
    steps = np.diff(clocks.gps_ns["TLSE"]) // NS_PER_S
    assert steps.max() >= 6300  # the gap is there
    bias = data.columns["clock_bias_s"]
    assert np.isnan(bias).sum() == data.info["n_gaps"] == int((steps // 30 - 1).sum())
    assert np.isfinite(bias).sum() == clocks.bias_s["TLSE"].size


def test_an_unknown_station_or_a_file_that_is_not_a_clock_product_is_named(real_data, tmp_path):
    clocks = read_station_clocks(real_data / "receivers/rinex/rtklib/igs15904.clk.gz")
    with pytest.raises(InputDataError, match="station == 'NOPE' is not in the file .176 stations"):
        station_clock_bias(clocks, "NOPE")
    with pytest.raises(InputDataError, match="not a RINEX clock file"):
        read_station_clocks(real_data / "receivers/rinex/rtklib/07590920.05n")
