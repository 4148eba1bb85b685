"""RINEX observation/navigation reading through georinex: GPS time kept, bad files named, skips counted."""

from __future__ import annotations

import re
from datetime import datetime

import numpy as np
import pytest

from chronofuse.io.rinex import (
    channel_clock_biases,
    count_epoch_records,
    read_gps_navigation,
    read_gps_observations,
    to_gps_ns,
)
from chronofuse.timescale import GPS_EPOCH
from chronofuse.validation import InputDataError

EPOCH2 = re.compile(r"^ \d\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d [ \d]\d\.\d{7}  \d")


def _rtklib(data_dir, name):
    return data_dir / "receivers" / "rinex" / "rtklib" / name


def test_observation_epochs_are_gps_time_as_integer_nanoseconds(data_dir):
    obs = read_gps_observations(_rtklib(data_dir, "07590920.05o"))
    assert obs.gps_ns.dtype == np.int64
    assert obs.gps_ns.size == 120
    # TIME OF FIRST OBS 2005-04-02 00:00:00 GPS: whole seconds since 1980-01-06, no leap seconds in GPS time
    first_s = (datetime(2005, 4, 2) - datetime(1980, 1, 6)).total_seconds()
    assert obs.gps_ns[0] == int(first_s) * 1_000_000_000
    # the navigation file's GPS week of the same day is 1316
    assert obs.gps_ns[0] // (604_800 * 1_000_000_000) == 1316
    assert obs.interval_s == 30.0
    np.testing.assert_array_equal(obs.approx_position_m, [-3976219.5082, 3382372.5671, 3652512.9849])
    assert obs.n_unreadable_epochs == 0


def test_pseudoranges_are_the_file_values(data_dir):
    obs = read_gps_observations(_rtklib(data_dir, "07590920.05o"))
    assert obs.code == "C1"
    # first epoch, first satellite G03: "55923622.160    24767686.375 ..." (L1, C1)
    assert obs.pseudorange_m[0, obs.satellites.index("G03")] == pytest.approx(24767686.375, abs=1e-6)
    assert obs.pseudorange_m[0, obs.satellites.index("G28")] == pytest.approx(21543408.487, abs=1e-6)
    assert np.isnan(obs.pseudorange_m[0, obs.satellites.index("G01")])


def test_rinex3_observation_file_gives_c1c(data_dir):
    obs = read_gps_observations(data_dir / "receivers" / "rinex" / "georinex" / "demo3.10o")
    assert obs.code == "C1C"
    assert obs.gps_ns.size == 2
    assert obs.interval_s == 30.0


def test_navigation_records_and_klobuchar_header(data_dir):
    nav = read_gps_navigation(_rtklib(data_dir, "07590920.05n"))
    np.testing.assert_allclose(nav.klobuchar_alpha, [1.1180e-08, 1.4900e-08, -5.9600e-08, -5.9600e-08])
    np.testing.assert_allclose(nav.klobuchar_beta, [8.8060e04, 1.6380e04, -1.9660e05, -1.3110e05])
    # first record of the file: PRN 1, toc 2005-04-02 02:00:00, af0 3.966595977540D-04, toe 525600
    toc = to_gps_ns(np.datetime64("2005-04-02T02:00:00"))
    row = [i for i, (s, t) in enumerate(zip(nav.satellites, nav.toc_gps_ns)) if s == "G01" and t == toc]
    assert len(row) == 1
    assert nav.params["af0_s"][row[0]] == pytest.approx(3.966595977540e-04, rel=1e-12)
    assert nav.params["toe_s"][row[0]] == 525600.0
    assert nav.params["week"][row[0]] == 1316


def test_gps_ns_of_the_gps_epoch_is_zero():
    assert to_gps_ns(GPS_EPOCH) == 0
    assert to_gps_ns(np.datetime64("1980-01-13T00:00:00.000000001")) == 604_800 * 10**9 + 1


@pytest.mark.parametrize("name,unreadable", [("badtime.10o", 1), ("junk_time_obs3.10o", 1), ("minimal2.10o", 0)])
def test_unreadable_epoch_records_are_counted(data_dir, name, unreadable):
    obs = read_gps_observations(data_dir / "receivers" / "rinex" / "georinex" / name)
    assert obs.n_unreadable_epochs == unreadable


def test_wrong_observation_count_is_reported(data_dir):
    obs = read_gps_observations(data_dir / "receivers" / "rinex" / "georinex" / "wrong_obs2_count.10o")
    assert any("number of observations" in p for p in obs.problems)


@pytest.mark.parametrize("name", ["blank.10o", "LICENSE-georinex.txt"])
def test_unusable_observation_files_raise_naming_the_file(data_dir, name):
    path = data_dir / "receivers" / "rinex" / "georinex" / name
    with pytest.raises(InputDataError) as info:
        read_gps_observations(path)
    assert info.value.source == str(path)


def test_blank_navigation_file_raises_naming_the_file(data_dir):
    path = data_dir / "receivers" / "rinex" / "georinex" / "blank.10n"
    with pytest.raises(InputDataError, match="no GPS ephemeris") as info:
        read_gps_navigation(path)
    assert info.value.source == str(path)


def _delete_epochs(text: str, drop: set[int]) -> str:
    """RINEX 2 text without the epoch records numbered in ``drop`` (0-based)."""
    lines = text.splitlines(keepends=True)
    out, epoch, body = [], -1, False
    for line in lines:
        if not body:
            out.append(line)
            body = "END OF HEADER" in line
            continue
        if EPOCH2.match(line):
            epoch += 1
        if epoch not in drop:
            out.append(line)
    return "".join(out)


def test_missing_epochs_are_nan_rows_and_counted(data_dir, tmp_path):
    src = _rtklib(data_dir, "30400920.05o")
    path = tmp_path / "30400920.05o"
    path.write_text(_delete_epochs(src.read_text(), {10, 11, 12, 50}))
    assert count_epoch_records(path) == 116
    obs = read_gps_observations(src)
    biases = channel_clock_biases(path, _rtklib(data_dir, "30400920.05n"), obs.approx_position_m)
    assert biases.n_skipped_epochs == 4
    assert biases.bias_s.shape[0] == 120
    empty = ~np.isfinite(biases.bias_s).any(axis=1)
    np.testing.assert_array_equal(np.flatnonzero(empty), [10, 11, 12, 50])
    assert biases.t_s[13] == 13 * 30.0
