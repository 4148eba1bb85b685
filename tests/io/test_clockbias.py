"""One receiver clock bias from CSV and UBX: the bias column found through the record reader's header, UBX
epochs on the grid with missing solutions counted, and the grid placement's errors."""

import numpy as np
import pytest

from chronofuse.io.clockbias import bias_column, n_skipped, read_clock_bias
from chronofuse.io.grid import regular_grid
from chronofuse.io.ubx import read_nav_clock
from chronofuse.validation import InputDataError


def test_the_clock_bias_column_is_found_by_name_and_scaled_by_its_unit(tmp_path):
    x_ns = np.array([1.5, 2.5, np.nan, 4.0, 5.25])
    path = tmp_path / "b.csv"
    path.write_text("t_s,temperature_c,clock_bias_ns\n" + "".join(
        f"{100 + k},{20 + k},{v}\n" for k, v in enumerate(x_ns)))
    assert bias_column(path) == "clock_bias_ns"
    data = read_clock_bias(path, 1.0)
    assert data.source == str(path) and data.time_scale == "file" and data.units["clock_bias_s"] == "s"
    np.testing.assert_array_equal(data.columns["clock_bias_s"], x_ns * 1e-9)
    np.testing.assert_array_equal(data.t_ns, (100 + np.arange(5)) * 10**9)
    assert n_skipped(data) == 1


def test_a_time_gap_in_the_csv_becomes_missing_epochs_on_the_file_time_axis(tmp_path):
    path = tmp_path / "g.csv"
    path.write_text("t_s,clock_bias_s\n0,1e-9\n1,2e-9\n4,3e-9\n5,4e-9\n")
    data = read_clock_bias(path, 1.0)
    np.testing.assert_array_equal(data.t_ns, np.arange(6) * 10**9)
    assert np.isnan(data.columns["clock_bias_s"][[2, 3]]).all() and n_skipped(data) == 2


def test_ubx_epochs_land_on_the_grid_at_their_time_of_week_with_the_receivers_values(real_data):
    from chronofuse.timescale import NS_PER_WEEK

    path = real_data / "receivers/gpsd/navisys-gr701w.log"
    data = read_clock_bias(path, 1.0)
    rec = read_nav_clock(path)  # the reader checked against gpsd's decoding in test_ubx
    assert data.time_scale == "gps" and data.t_ns[0] % NS_PER_WEEK == rec.itow_ms[0] * 10**6
    assert np.all(np.diff(data.t_ns) == 10**9)
    slot = np.rint(rec.t_s).astype(int)
    bias = data.columns["clock_bias_s"]
    np.testing.assert_array_equal(bias[slot], rec.clock_bias_s)
    n_missing = bias.size - rec.t_s.size
    assert n_missing == int(np.isnan(bias).sum()) and n_skipped(data) == n_missing + rec.n_skipped_frames


def test_a_rinex_file_holds_no_single_clock_bias(real_data):
    with pytest.raises(InputDataError, match="07590920.05o: a rinex-obs file holds no single receiver clock bias"):
        read_clock_bias(real_data / "receivers/rinex/rtklib/07590920.05o", 1 / 30)


def test_grid_placement_names_the_epoch_that_goes_back_or_changes_the_interval():
    t, v = regular_grid(np.array([10.0, 11.0, 13.0]), np.array([1.0, 2.0, 3.0]), 1.0, "src")
    np.testing.assert_array_equal(t, [10.0, 11.0, 12.0, 13.0])
    np.testing.assert_array_equal(np.isnan(v), [False, False, True, False])
    with pytest.raises(InputDataError, match="src: epoch 3: time is not increasing"):
        regular_grid(np.array([0.0, 1.0, 0.5]), np.zeros(3), 1.0, "src")
    with pytest.raises(InputDataError, match="src: epoch 3: time step 1.5 s is not a whole number"):
        regular_grid(np.array([0.0, 1.0, 2.5]), np.zeros(3), 1.0, "src")
