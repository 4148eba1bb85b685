"""One receiver clock bias from CSV and UBX: the bias column found through the record reader's header, UBX
epochs on the grid with missing solutions counted, and the grid placement's errors."""

import numpy as np
import pytest

from chronofuse.io.clockbias import ClockBiasInput, bias_column, read_clock_bias
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
    assert isinstance(data, ClockBiasInput) and data.source == str(path)
    np.testing.assert_array_equal(data.bias_s, x_ns * 1e-9)
    np.testing.assert_array_equal(data.t_s, 100.0 + np.arange(5))
    assert data.n_skipped == 1


def test_a_time_gap_in_the_csv_becomes_missing_epochs_on_the_file_time_axis(tmp_path):
    path = tmp_path / "g.csv"
    path.write_text("t_s,clock_bias_s\n0,1e-9\n1,2e-9\n4,3e-9\n5,4e-9\n")
    data = read_clock_bias(path, 1.0)
    np.testing.assert_array_equal(data.t_s, np.arange(6.0))
    assert np.isnan(data.bias_s[[2, 3]]).all() and data.n_skipped == 2


def test_ubx_epochs_land_on_the_grid_at_their_time_of_week_with_the_receivers_values(real_data):
    path = real_data / "receivers/gpsd/navisys-gr701w.log"
    data = read_clock_bias(path, 1.0)
    rec = read_nav_clock(path)  # the reader checked against gpsd's decoding in test_ubx
    assert data.t_s[0] == rec.itow_ms[0] / 1000.0 and np.all(np.diff(data.t_s) == 1.0)
    slot = np.rint(rec.t_s).astype(int)
    np.testing.assert_array_equal(data.bias_s[slot], rec.clock_bias_s)
    n_missing = data.bias_s.size - rec.t_s.size
    assert n_missing == int(np.isnan(data.bias_s).sum()) and data.n_skipped == n_missing + rec.n_skipped_frames


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
