"""RTKLIB solution (.pos) and status (.stat) files written by RTKLIB's rnx2rtkp (Debian 2.4.3 b34) from an IGS
station's real RINEX: the two outputs of one run agree epoch by epoch through independent geodesy."""

import gzip
from pathlib import Path

import numpy as np
import pymap3d
import pytest

from chronofuse.io.field_logs import read_log, series_record
from chronofuse.io.formats import sniff_format
from chronofuse.validation import InputDataError

DATA = Path(__file__).parents[1] / "data" / "logs" / "rtklib"
POS = DATA / "bor1-spp.pos.gz"
STAT = DATA / "bor1-spp.pos.stat.gz"
GPS_EPOCH_UNIX_S = 315_964_800


def test_the_solution_and_its_status_file_are_told_apart():
    assert sniff_format(POS) == "rtklib-pos" and sniff_format(STAT) == "rtklib-stat"


def test_the_pos_rows_and_the_stat_positions_are_the_same_solution_on_the_same_epochs():
    (pos,) = read_log(POS)
    (stat,) = read_log(STAT)
    assert pos.time_scale == stat.time_scale == "gps" and pos.n == stat.n == 120
    np.testing.assert_array_equal(pos.t_ns, stat.t_ns)  # "2024/02/04 00:00:00" GPST and week 2299 tow 604800
    x, y, z = pymap3d.geodetic2ecef(pos.columns["lat_deg"], pos.columns["lon_deg"], pos.columns["height_m"])
    for mine, theirs in ((x, "x_m"), (y, "y_m"), (z, "z_m")):
        np.testing.assert_allclose(mine, stat.columns[theirs], atol=2e-3)  # .pos prints 1e-9 deg, 0.1 mm
    assert set(pos.columns["quality"]) == {5.0} and pos.ok.all()  # single-point solutions throughout


def test_the_receiver_clock_bias_is_read_in_seconds_from_the_clk_lines():
    (stat,) = read_log(STAT)
    text = gzip.decompress(STAT.read_bytes()).decode().splitlines()
    first_clk = next(line for line in text if line.startswith("$CLK"))
    assert first_clk.split(",")[5] == "8096.392"
    assert stat.columns["clock_bias_s"][0] == pytest.approx(8096.392e-9, rel=1e-12)
    assert stat.t_ns[0] == (1391040000) * 10**9  # 2024-02-04 00:00:00 GPST in s since 1980-01-06


def test_the_clock_bias_becomes_a_30_s_phase_record_without_gaps():
    (stat,) = read_log(STAT)
    rec = series_record(stat)
    assert rec.kind == "phase" and 1 / rec.rate_hz == pytest.approx(30.0) and rec.n_gaps == 0


def test_a_position_series_has_no_clock_and_says_so():
    (pos,) = read_log(POS)
    with pytest.raises(InputDataError, match="no offset series"):
        series_record(pos)


def test_a_damaged_pos_row_names_its_line(tmp_path):
    lines = gzip.decompress(POS.read_bytes()).decode().splitlines()
    lines[12] = lines[12][:30]
    path = tmp_path / "cut.pos"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputDataError, match=r"cut\.pos:13: "):
        read_log(path)
