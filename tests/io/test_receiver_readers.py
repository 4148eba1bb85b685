"""The readers on real and damaged captures: every capture reads without a traceback, damage is counted
and the good records around it are kept, bursts split anywhere give the same result, and fuzzed bytes
never crash them."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from chronofuse.io.frames import FrameScanner, scan_bytes
from chronofuse.io.inspect import read_bytes, read_capture
from chronofuse.timescale import NS_PER_S, gps_ns_to_datetime64

from .conftest import receivers_dir

ALL_CAPTURES = sorted(
    str(p.relative_to(receivers_dir()))
    for p in receivers_dir().rglob("*")
    if p.is_file() and (p.suffix in (".log", ".ubx") or "gpsd" in p.parts and not p.name.endswith(".chk"))
    and not p.name.endswith(".gz")  # gzipped copies of two captures, for the tests of compressed input
    and not p.name.startswith(("COPYING", "LICENSE"))
)

GGA = b"$GPGGA,120000.00,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*4A\r\n"


def _nmea(body: str) -> bytes:
    check = 0
    for ch in body.encode():
        check ^= ch
    return f"${body}*{check:02X}\r\n".encode()


def _burst(hhmmss: str, ddmmyy: str = "010125", mode: int = 3, sats: int = 8) -> bytes:
    return (_nmea(f"GPRMC,{hhmmss}.00,A,4807.038,N,01131.000,E,0.0,0.0,{ddmmyy},,,A")
            + _nmea(f"GPGGA,{hhmmss}.00,4807.038,N,01131.000,E,1,{sats:02d},0.9,545.4,M,46.9,M,,")
            + _nmea(f"GNGSA,A,{mode},01,02,03,04,,,,,,,,,1.8,0.9,1.5,1")
            + _nmea(f"GNGSA,A,{mode},65,66,,,,,,,,,,,1.8,0.9,1.5,2"))


def _labels(capture) -> list[str]:
    return list(np.datetime_as_string(gps_ns_to_datetime64(capture.utc_ns()), unit="s"))


def test_the_capture_list_holds_every_gpsd_log_and_the_ubx_captures():
    assert sum(name.startswith("gpsd/") for name in ALL_CAPTURES) == 199
    assert sum(name.startswith("ubx/") for name in ALL_CAPTURES) >= 15


@pytest.mark.parametrize("name", ALL_CAPTURES)
def test_every_real_capture_reads_without_a_traceback(receivers, name):
    capture = read_capture(receivers / name)
    assert capture.frames.n_bytes == (receivers / name).stat().st_size
    assert np.all(np.diff(capture.rows["gps_ns"]) > 0)


def test_a_bad_ubx_checksum_is_counted_and_the_frames_around_it_kept(receivers):
    good = read_capture(receivers / "ubx" / "pygpsdata-MIXED3.log") if (receivers / "ubx" / "pygpsdata-MIXED3.log").exists() else None
    bad = read_capture(receivers / "ubx" / "pygpsdata-BADCK2.log")
    assert bad.frames.ubx_bad_checksum == 2
    assert sum(bad.frames.messages[n] for n in bad.frames.messages if not n.startswith("G")) > 0
    assert good is None or good.frames.ubx_bad_checksum == 0


@pytest.mark.parametrize("name", ["pygpsdata-BADEOF1.log", "pygpsdata-BADEOF2.log", "pygpsdata-BADEOF3.log"])
def test_a_ubx_frame_cut_by_the_end_of_the_file_is_counted_as_truncated(receivers, name):
    capture = read_capture(receivers / "ubx" / name)
    assert capture.frames.truncated == 1
    assert sum(capture.frames.messages.values()) > 0


def test_nmea_damage_is_counted_by_kind_and_the_good_bursts_kept():
    bursts = [_burst(f"1200{s:02d}") for s in range(6)]
    broken_checksum = bursts[1].replace(b"*", b"*F", 1)[:-3] + b"\r\n"  # RMC's checksum altered
    no_checksum = b"$GPGGA,120002.00,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\r\n"
    garbage = bytes(range(0, 256, 7)) + b"$\x00\xff$GP"
    unknown_talker = _nmea("XXGGA,120004.00,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,")
    data = (bursts[0] + broken_checksum + no_checksum + garbage + bursts[3] + unknown_talker
            + bursts[4][:40] + bursts[5])
    capture = read_bytes([data])
    stats = capture.frames
    assert stats.nmea_no_checksum == 1
    assert stats.nmea_bad_checksum + stats.nmea_malformed >= 2
    assert stats.unknown_talkers["XX"] == 1
    assert stats.unframed_bytes > 0
    assert _labels(capture) == ["2025-01-01T12:00:00", "2025-01-01T12:00:01", "2025-01-01T12:00:03",
                                "2025-01-01T12:00:05"]


def test_nmea_4_10_gsa_per_constellation_pool_their_satellites_for_one_solution():
    capture = read_bytes([_nmea("GNGSA,A,3,01,02,03,04,,,,,,,,,1.8,0.9,1.5,1")
                          + _nmea("GNGSA,A,3,65,66,,,,,,,,,,,1.8,0.9,1.5,2")
                          + _nmea("GNRMC,120000.00,A,4807.038,N,01131.000,E,0.0,0.0,010125,,,A")])
    assert capture.rows["n_sats"].tolist() == [6]
    assert capture.rows["pdop"].tolist() == [1.8]
    assert capture.rows["fix_mode"].tolist() == [3]


@pytest.mark.parametrize("talker", ["GB", "BD"])
def test_beidou_sentences_are_decoded_under_both_talker_ids(talker):
    capture = read_bytes([_nmea(f"{talker}RMC,120000.00,A,4807.038,N,01131.000,E,0.0,0.0,010125,,,A")
                          + _nmea(f"{talker}GGA,120000.00,4807.038,N,01131.000,E,1,07,0.9,545.4,M,46.9,M,,")])
    assert capture.rows["n_sats"].tolist() == [7]
    assert not capture.frames.unknown_talkers


def test_a_two_digit_rmc_year_is_placed_in_the_gps_era():
    early = read_bytes([_burst("000000", "010199")])
    late = read_bytes([_burst("000000", "010179")])
    assert _labels(early) == ["1999-01-01T00:00:00"]
    assert _labels(late) == ["2079-01-01T00:00:00"]


def test_a_burst_after_midnight_without_a_date_moves_to_the_next_day():
    data = _burst("235959", "311224") + _nmea("GPGGA,000000.00,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,")
    assert _labels(read_bytes([data])) == ["2024-12-31T23:59:59", "2025-01-01T00:00:00"]


def test_the_gps_label_of_an_nmea_epoch_adds_the_leap_seconds_of_its_date():
    capture = read_bytes([_burst("120000", "010125")])
    assert capture.rows["leap_s"].tolist() == [18]
    assert int(capture.rows["gps_ns"][0] - capture.utc_ns()[0]) == 18 * NS_PER_S


def test_splitting_the_stream_anywhere_gives_the_same_epochs_and_counts(receivers):
    data = (receivers / "gpsd" / "ublox-zed-f9t-ubx_nmea_l5.log").read_bytes()
    whole = read_bytes([data])
    rng = np.random.default_rng(12)
    cuts = np.sort(rng.integers(0, len(data), 40))
    pieces = [data[a:b] for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(data)])]
    split = read_bytes(pieces)
    assert split.frames.as_dict() == whole.frames.as_dict()
    for key, value in whole.rows.items():
        np.testing.assert_array_equal(split.rows[key], value)


def test_tim_tp_qerr_is_paired_with_the_pulse_it_announces_not_the_epoch_it_arrives_in(receivers):
    from chronofuse.io.frames import scan_bytes as scan
    from pyubx2 import UBXReader

    log = receivers / "gpsd" / "u-blox-m8t-time.log"
    frames, _ = scan(log.read_bytes())
    first_tp = next(UBXReader.parse(f.raw) for f in frames if f.name == "TIM-TP")
    capture = read_capture(log)
    # TIM-TP announces the pulse at towMS in UTC (timeBase 1): that pulse's GPS time is towMS + leap
    pulse_gps_ns = first_tp.week * 604_800 * NS_PER_S + first_tp.towMS * 1_000_000 + 18 * NS_PER_S
    i = int(np.searchsorted(capture.rows["gps_ns"], pulse_gps_ns))
    assert capture.rows["gps_ns"][i] == pulse_gps_ns
    assert capture.rows["qerr_s"][i] == pytest.approx(first_tp.qErr * 1e-12)
    # 152 TIM-TP: 150 announce a pulse of a logged epoch; the first announces the pulse before the
    # first navigation epoch, the last the pulse after the recording ends: counted, not made epochs
    assert capture.ubx.decoded["TIM-TP"] == 152
    assert np.isfinite(capture.rows["qerr_s"]).sum() == 150
    assert capture.ubx.pulses_without_epoch == 2
    assert (capture.rows["fix_mode"] >= 2).all()  # no epoch without a fix is made of a lone pulse


def test_nav_dop_invalid_99_99_is_missing_not_a_dilution(receivers):
    from chronofuse.io.frames import scan_bytes as scan
    from pyubx2 import UBXReader

    # the M8T timing receiver is in fixed-position mode: NAV-DOP sends 99.99 for pDOP, hDOP and vDOP
    log = receivers / "gpsd" / "u-blox-m8t-time.log"
    frames, _ = scan(log.read_bytes())
    sent = [UBXReader.parse(f.raw) for f in frames if f.name == "NAV-DOP"]
    assert sent and all(m.hDOP == 99.99 and m.pDOP == 99.99 and m.vDOP == 99.99 for m in sent)
    capture = read_capture(log)
    for name in ("pdop", "hdop", "vdop"):
        assert np.isnan(capture.rows[name]).all(), name
    # its gDOP and tDOP are real values and are kept, equal to what the receiver sent
    assert np.isfinite(capture.rows["gdop"]).all() and capture.rows["gdop"].max() < 99.99
    assert sorted(set(np.round(capture.rows["tdop"], 2))) == sorted({round(m.tDOP, 2) for m in sent})


def test_the_leap_count_comes_from_the_receiver_not_the_table(receivers):
    capture = read_capture(receivers / "gpsd" / "ublox-lea-4t.log")  # 2009: GPS-UTC 15 s, announced
    assert set(capture.rows["leap_s"].tolist()) == {15}
    capture = read_capture(receivers / "gpsd" / "ublox-aek-4t.log")  # 2007: 14 s
    assert set(capture.rows["leap_s"].tolist()) == {14}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(st.binary(max_size=40), st.sampled_from([GGA, _burst("120001"), b"\xb5b", b"$GP",
                                                                   b"\xd3\x00\x13", b"*", b"\r\n"])),
                max_size=30),
       st.integers(min_value=1, max_value=64))
def test_fuzzed_bytes_never_crash_the_readers_and_every_byte_is_accounted(pieces, chunk):
    data = b"".join(pieces)
    capture = read_bytes([data[k:k + chunk] for k in range(0, len(data), chunk)])
    assert capture.frames.n_bytes == len(data)
    assert np.all(np.diff(capture.rows["gps_ns"]) > 0)
    whole_frames, _ = scan_bytes(data)
    scanner = FrameScanner()
    split_frames = []
    for k in range(0, len(data), chunk):
        split_frames += scanner.feed(data[k:k + chunk])
    split_frames += scanner.close()
    assert [(f.offset, f.raw) for f in split_frames] == [(f.offset, f.raw) for f in whole_frames]


def test_a_hash_after_a_stray_byte_is_not_a_comment_even_when_the_stray_byte_came_in_an_earlier_chunk():
    """'#' opens a comment line only at a line start; a byte-at-a-time feed must not forget the byte
    before it (found by the fuzzer: b'\\x00#' then an RMC lost the RMC when fed one byte at a time)."""
    data = b"\x00#" + _burst("120001")
    whole, _ = scan_bytes(data)
    scanner = FrameScanner()
    split = [f for k in range(len(data)) for f in scanner.feed(data[k:k + 1])] + scanner.close()
    assert [f.offset for f in split] == [f.offset for f in whole]
    assert whole[0].offset == 2 and whole[0].name == "GPRMC"
    assert scanner.stats.comment_lines == 0


def test_a_capture_is_the_one_receiver_epochs_record_and_exports_its_columns(receivers):
    from chronofuse.epochs import EXPORT_COLUMNS

    capture = read_capture(receivers / "gpsd" / "ublox-zed-f9t-ubx_nmea_l5.log")
    epochs = capture.epochs
    assert epochs.shape == (1, 1, capture.n_epochs)
    np.testing.assert_array_equal(epochs.utc_ns()[0, 0], capture.utc_ns())
    frame = capture.to_frame()
    assert tuple(frame.columns) == EXPORT_COLUMNS
    # NAV-CLOCK clkB of the first epoch, in seconds
    assert np.isfinite(frame["clock_bias_s"]).sum() == 9


@pytest.mark.parametrize("name", ["mt3339.log", "nl551e.log", "gr601-w.log", "ublox-lea-5h.log",
                                  "sl869.log", "navika-100-fix.log", "et-332.log", "magellan315.log"])
def test_the_pdop_of_the_gsv_geometry_is_the_receivers_own_gsa_pdop(receivers, name):
    """GDOP/TDOP of NMEA receivers come from the GSV elevations/azimuths of the satellites GSA lists as
    used; the PDOP of that same geometry must be what the receiver itself reports in GSA (integer-degree
    angles and the receivers' 1-2 decimal PDOP leave a few per mille)."""
    from chronofuse.io.frames import scan_bytes as scan
    from chronofuse.io.nmea import NmeaDecodeStats, NmeaEpochBuilder, decode_nmea

    frames, _ = scan((receivers / "gpsd" / name).read_bytes())
    builder = NmeaEpochBuilder()
    decode_nmea(frames, builder, NmeaDecodeStats())
    rows = builder.rows()
    ok = np.isfinite(rows["pdop"]) & np.isfinite(rows["geometry_pdop"])
    assert ok.sum() >= 3
    np.testing.assert_allclose(rows["geometry_pdop"][ok], rows["pdop"][ok], rtol=0.03, atol=0.02)
    assert np.all(rows["gdop"][ok] > rows["geometry_pdop"][ok])


def test_geometry_dops_of_a_symmetric_constellation_match_the_closed_form():
    from chronofuse.io.nmea import geometry_dops

    # zenith + three at 0 deg elevation 120 deg apart: H^T H = diag(3/2, 3/2, 1, 4) plus the z-clock
    # coupling [[1, 1], [1, 4]] -> G_zz = 4/3, G_tt = 1/3, G_xx = G_yy = 2/3
    gdop, tdop, pdop = geometry_dops([(90.0, 0.0), (0.0, 0.0), (0.0, 120.0), (0.0, 240.0)])
    assert pdop == pytest.approx(np.sqrt(2 / 3 + 2 / 3 + 4 / 3))
    assert tdop == pytest.approx(np.sqrt(1 / 3))
    assert gdop == pytest.approx(np.sqrt(2 / 3 + 2 / 3 + 4 / 3 + 1 / 3))
