"""A recording's clock bias as one gridded epoch record: the capture reader's NAV-CLOCK values against the
message decoded by hand from the u-blox interface description (and by pyubx2), gaps kept where solutions are
missing, gzip told by content, and one-line refusals for recordings that carry no clock bias."""

from __future__ import annotations

import gzip
import sys
from pathlib import Path

import numpy as np
import pytest
from pyubx2 import ERR_IGNORE, UBX_PROTOCOL, UBXReader

from chronofuse.io.capture_series import TIME_TOLERANCE, read_clock_series
from chronofuse.io.clockbias import read_clock_bias
from chronofuse.io.inspect import read_capture
from chronofuse.io.records import capture_record
from chronofuse.io.ubx import read_nav_clock
from chronofuse.timescale import NS_PER_WEEK
from chronofuse.validation import InputDataError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ubx_by_hand import NAV_CLOCK, nav_clock_by_hand  # noqa: E402

def test_a_mixed_nmea_and_ubx_capture_gives_pyubx2s_nav_clock_values_at_their_gps_epochs(receivers):
    path = receivers / "gpsd" / "ublox-zed-f9t-ubx_nmea_l5.log"
    with path.open("rb") as stream:
        ref = [(m.iTOW, m.clkB * 1e-9, m.clkD * 1e-9, m.tAcc * 1e-9)
               for _, m in UBXReader(stream, protfilter=UBX_PROTOCOL, quitonerror=ERR_IGNORE)
               if m is not None and m.identity == "NAV-CLOCK"]
    series = read_clock_series(path)
    assert series.interval_ns == 1_000_000_000 and series.info["n_gaps"] == 0 and len(ref) == 9
    np.testing.assert_array_equal(series.t_ns % NS_PER_WEEK, [r[0] * 1_000_000 for r in ref])
    np.testing.assert_array_equal(series.columns["clock_bias_s"], [r[1] for r in ref])
    np.testing.assert_array_equal(series.columns["clock_drift_s_per_s"], [r[2] for r in ref])
    np.testing.assert_array_equal(series.columns["time_acc_s"], [r[3] for r in ref])
    # the GPS week is the capture's own (its NMEA dates and UBX weeks), not a guess
    assert np.all(series.t_ns // NS_PER_WEEK == read_capture(path).rows["gps_ns"][0] // NS_PER_WEEK)


def test_a_solution_cut_out_of_the_capture_leaves_a_gap_at_its_epoch_not_a_shift(receivers, tmp_path):
    blob = gzip.decompress((receivers / "gpsd" / "ublox-zed-f9p_hpg1.11.log.gz").read_bytes())
    itow, bias, _ = nav_clock_by_hand(blob)
    frames = [k for k in range(len(blob)) if blob.startswith(NAV_CLOCK, k)]
    cut = frames[200]
    damaged = tmp_path / "cut.ubx"
    damaged.write_bytes(blob[:cut] + blob[cut + 28:])  # one NAV-CLOCK frame gone
    series = read_clock_series(damaged)
    assert series.t_ns.size == itow.size and series.info["n_gaps"] == 1
    assert np.isnan(series.columns["clock_bias_s"][200]) and np.isfinite(np.delete(series.columns["clock_bias_s"], 200)).all()
    np.testing.assert_array_equal(np.delete(series.columns["clock_bias_s"], 200), np.delete(bias, 200))
    # every solution sits within the tolerance of its slot (iTOW steps by 999 and 1001 ms here)
    tow_ms = (series.t_ns % NS_PER_WEEK) // 1_000_000
    assert np.abs(np.delete(tow_ms, 200) - np.delete(itow, 200)).max() <= TIME_TOLERANCE * 1000
    assert set(np.diff(itow)) == {999, 1000, 1001}
    # ... and the series says how far: 1 ms at most, the rms over the solutions
    kept = np.delete(itow, 200)
    off_ms = (kept - kept[0]) - np.rint((kept - kept[0]) / 1000) * 1000
    assert series.info["jitter_max_s"] == pytest.approx(np.abs(off_ms).max() / 1000) == pytest.approx(1e-3)
    assert series.info["jitter_rms_s"] == pytest.approx(np.sqrt(np.mean(off_ms**2)) / 1000)


def test_gzip_content_without_a_gz_name_reads_as_the_plain_capture(receivers, tmp_path):
    plain = receivers / "gpsd" / "navisys-gr701w.log"
    packed = tmp_path / "navisys.bin"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    a, b = read_clock_series(plain), read_clock_series(packed)
    np.testing.assert_array_equal(a.t_ns, b.t_ns)
    np.testing.assert_array_equal(a.columns["clock_bias_s"], b.columns["clock_bias_s"])
    itow, bias, _ = nav_clock_by_hand(plain.read_bytes())
    slot = (itow - itow[0]) // 1000
    np.testing.assert_array_equal(a.columns["clock_bias_s"][slot], bias)
    assert a.info["n_gaps"] == a.t_ns.size - itow.size


def test_the_receivers_no_fix_epochs_are_flagged_for_the_detector(receivers):
    path = receivers / "gpsd" / "navisys-gr701w.log"
    series = read_clock_series(path)
    capture = read_capture(path)
    with_bias = np.isfinite(capture.rows["clock_bias_s"])
    no_fix = capture.rows["fix_mode"][with_bias] == 1
    assert no_fix.any() and int((~series.valid).sum()) == int(no_fix.sum())
    assert read_clock_bias(path).valid.sum() == series.valid.sum()
    # the same epochs as pyubx2's stream reader flags from NAV-SOL's gpsFixOk and gpsFix
    ref = read_nav_clock(path)
    slot = (ref.itow_ms - ref.itow_ms[0]) // 1000
    np.testing.assert_array_equal(series.valid[slot], ref.fix_ok)


@pytest.mark.parametrize("name, fragments", [
    ("gpsd/ac12.log", ("NMEA 0183 carries no receiver clock bias", "UBX NAV-CLOCK")),
    ("gpsd/ublox-neo-m8t.log", ("no UBX NAV-CLOCK message", "NAV-SOL")),
    ("ubx/pygpsdata-BADEOF1.log", ("no UBX NAV-CLOCK",)),
])
def test_a_recording_without_clock_bias_is_refused_in_one_line_naming_the_file(receivers, name, fragments):
    with pytest.raises(InputDataError) as info:
        read_clock_series(receivers / name)
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(receivers / name))
    for fragment in fragments:
        assert fragment in message


def test_a_single_solution_needs_the_rate_and_a_changed_rate_is_named(receivers, tmp_path):
    with pytest.raises(InputDataError, match="one epoch and no sampling rate"):
        read_clock_series(receivers / "ubx" / "pygpsdata-NAV.log")
    assert read_clock_series(receivers / "ubx" / "pygpsdata-NAV.log", rate_hz=1.0).n_epochs == 1
    with pytest.raises(InputDataError, match="not a whole number of 0.3 s intervals"):
        read_clock_series(receivers / "gpsd" / "navisys-gr701w.log", rate_hz=1 / 0.3)


def test_the_stability_record_of_a_capture_is_its_bias_as_phase_or_its_drift_as_frequency(receivers):
    path = receivers / "gpsd" / "ublox-zed-f9r.log"
    itow, bias, drift = nav_clock_by_hand(path.read_bytes())
    phase, freq = capture_record(path, "phase"), capture_record(path, "freq")
    assert phase.rate_hz == freq.rate_hz == 1.0 and phase.n_gaps == 0 and itow.size == 30
    np.testing.assert_array_equal(phase.values, bias)
    np.testing.assert_array_equal(freq.values, drift)
    np.testing.assert_array_equal(phase.t_ns % NS_PER_WEEK, itow * 1_000_000)


def test_a_gzipped_rinex_clock_product_reads_as_the_plain_one(receivers):
    plain = read_capture(receivers / "rinex" / "gnss_lib_py" / "grg21553.clk")
    packed = read_capture(receivers / "rinex" / "gnss_lib_py" / "grg21553.clk.gz")
    assert packed.receivers == plain.receivers and plain.n_epochs == 44
    np.testing.assert_array_equal(packed.rows["gps_ns"], plain.rows["gps_ns"])
    np.testing.assert_array_equal(packed.rows["clock_bias_s"], plain.rows["clock_bias_s"])
    series = read_clock_series(receivers / "rinex" / "gnss_lib_py" / "grg21553.clk.gz")
    have = np.isfinite(plain.rows["clock_bias_s"])
    assert series.interval_ns == 30 * 10**9 and series.t_ns.size - series.info["n_gaps"] == int(have.sum())
    on_grid = series.columns["clock_bias_s"][np.isfinite(series.columns["clock_bias_s"])]
    np.testing.assert_array_equal(on_grid, plain.rows["clock_bias_s"][have])
