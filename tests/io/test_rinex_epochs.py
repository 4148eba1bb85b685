"""RINEX observation and clock files as receiver epochs, checked against the files' own text."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.io.inspect import read_capture
from chronofuse.io.rinex import read_gps_navigation
from chronofuse.io.rinex_epochs import read_rinex_clock_epochs, read_rinex_observation_epochs, rinex_kind
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns
from chronofuse.validation import InputDataError

from .conftest import receivers_dir

RINEX = sorted(p for p in (receivers_dir() / "rinex").rglob("*") if p.is_file() and rinex_kind(p) is not None)


def test_the_rinex_captures_are_recognised_by_kind():
    kinds = {rinex_kind(p)[1] for p in RINEX}
    assert kinds == {"obs", "nav", "clock"}
    assert len(RINEX) == 22  # 12 georinex, 4 gnss_lib_py, 6 RTKLIB (two clock products gzipped, told by content)


@pytest.mark.parametrize("path", RINEX, ids=lambda p: p.name)
def test_every_rinex_capture_reads_or_is_refused_in_one_named_error(path):
    kind = rinex_kind(path)[1]
    try:
        if kind == "nav":
            read_gps_navigation(path)
        else:
            capture = read_capture(path)
            assert capture.n_epochs >= 1 and np.all(np.diff(capture.rows["gps_ns"]) > 0)
    except InputDataError as err:
        assert path.name in str(err)


def test_observation_epochs_count_the_satellites_the_epoch_lines_announce():
    path = receivers_dir() / "rinex" / "rtklib" / "07590920.05o"
    epochs = read_rinex_observation_epochs(path)
    lines = [ln for ln in path.read_text().splitlines() if ln[:3] == " 05" and ln[28:29] in "01"]
    announced = [int(ln[29:32]) for ln in lines]
    assert epochs.shape == (1, 1, 120)
    assert epochs.n_sats[0, 0].tolist() == announced
    first = np.datetime64("2005-04-02T00:00:00", "ns")
    assert int(epochs.gps_ns[0]) == int(datetime64_to_gps_ns(first))
    assert int(epochs.gps_ns[1] - epochs.gps_ns[0]) == 30 * NS_PER_S


def test_clock_file_stations_carry_their_ar_clock_biases():
    path = receivers_dir() / "rinex" / "rtklib" / "igs15904.clk"
    names, epochs, bad = read_rinex_clock_epochs(path)
    assert bad == 0 and len(names) == 176
    j = names.index("ABPO")
    # the record as printed: "AR ABPO 2010 07 01 00 00  0.000000  2   -5.778304214828e-08 ..."
    assert epochs.clock_bias_s[0, j, 0] == pytest.approx(-5.778304214828e-08, rel=1e-12)
    assert set(epochs.leap_s.ravel().tolist()) == {15}  # the header's LEAP SECONDS (2010)


def test_a_rinex_3_04_clock_product_of_a_time_laboratory_is_read():
    path = receivers_dir() / "rinex" / "gnss_lib_py" / "COD0MGXFIN_20211180000_01D_30S_CLK.CLK"
    capture = read_capture(path, receiver="WAB200CHE")
    assert "WAB200CHE" in capture.receivers
    assert np.isfinite(capture.rows["clock_bias_s"]).sum() > 100


def _clock_file(tmp_path, version: str, leap_lines: list[str], year: int = 2010) -> "Path":
    head = [f"{version:>9}           C                                       RINEX VERSION / TYPE",
            "   GPS                                                      TIME SYSTEM ID"]
    head += leap_lines
    head += ["                                                            END OF HEADER"]
    body = [f"AR ABCD {year} 06 01 00 00  0.000000  1    1.234567890123E-06"]
    path = tmp_path / f"v{version}.clk"
    path.write_text("\n".join(head + body) + "\n")
    return path


def test_a_rinex_clock_3_04_leap_seconds_record_is_tai_minus_utc(tmp_path):
    import warnings as _w

    from chronofuse.io.rinex_epochs import read_rinex_clock_epochs

    # 2010: TAI - UTC 34 s, GPS - UTC 15 s. Version 3.04 defines LEAP SECONDS as TAI - UTC.
    path = _clock_file(tmp_path, "3.04", ["    34                                                      LEAP SECONDS"])
    with _w.catch_warnings():
        _w.simplefilter("error")  # it agrees with the table once read as the format defines it
        _, epochs, _ = read_rinex_clock_epochs(path)
    assert int(epochs.leap_s[0, 0, 0]) == 15
    # LEAP SECONDS GNSS (3.04) is GNSS - UTC as given, and wins
    path = _clock_file(tmp_path, "3.04", ["    34                                                      LEAP SECONDS",
                                          "    15                                                      LEAP SECONDS GNSS"])
    assert int(read_rinex_clock_epochs(path)[1].leap_s[0, 0, 0]) == 15


def test_a_rinex_clock_3_00_leap_seconds_record_is_gps_minus_utc_and_a_misfit_is_warned(tmp_path):
    import pytest as _pytest

    from chronofuse.io.rinex_epochs import read_rinex_clock_epochs

    path = _clock_file(tmp_path, "3.00", ["    15                                                      LEAP SECONDS"])
    assert int(read_rinex_clock_epochs(path)[1].leap_s[0, 0, 0]) == 15
    path = _clock_file(tmp_path, "3.00", ["    34                                                      LEAP SECONDS"])
    with _pytest.warns(UserWarning, match="GPS - UTC = 34 s"):
        _, epochs, _ = read_rinex_clock_epochs(path)
    assert int(epochs.leap_s[0, 0, 0]) == 34  # read as the format defines it, and said


def test_the_real_clock_products_leap_counts_are_their_gps_minus_utc(receivers):
    from chronofuse.io.rinex_epochs import clock_header_leap

    rinex = receivers / "rinex"
    assert clock_header_leap(rinex / "rtklib" / "igs15904.clk") == 15  # 3.00, 2010
    assert clock_header_leap(rinex / "gnss_lib_py" / "COD0MGXFIN_20211180000_01D_30S_CLK.CLK") == 18  # 3.04 GNSS
    assert clock_header_leap(rinex / "gnss_lib_py" / "COD0OPSRAP_20230730000_01D_30S_CLK.CLK") == 18  # 2.00, 2023
