"""UBX NAV-CLOCK reader against gpsd's reference decoding, and corrupt frames counted, never fatal."""

from __future__ import annotations

import gzip
import json
from datetime import datetime, timezone

import numpy as np
import pytest

from chronofuse.io.ubx import read_nav_clock, unwrap_itow_ms
from chronofuse.timescale import MS_PER_WEEK as WEEK_MS
from chronofuse.validation import InputDataError

GPS_EPOCH = datetime(1980, 1, 6, tzinfo=timezone.utc)


def _gpsd_clock_bias_ns(chk_path) -> dict[int, int]:
    """gpsd's TPV clock bias (ns) keyed by GPS time of week (ms), from its regression .chk file (gzipped)."""
    out = {}
    for line in gzip.open(chk_path, "rt", errors="replace").read().splitlines():
        if '"clockbias"' not in line or not line.startswith("{"):
            continue
        tpv = json.loads(line)
        utc = datetime.fromisoformat(tpv["time"].replace("Z", "+00:00"))
        gps_s = (utc - GPS_EPOCH).total_seconds() + tpv["leapseconds"]
        out[int(round(gps_s * 1000)) % WEEK_MS] = tpv["clockbias"]
    return out


def test_nav_clock_bias_matches_gpsd_decoding(real_data):
    path = real_data / "receivers" / "gpsd" / "navisys-gr701w.log"
    rec = read_nav_clock(path)
    reference = _gpsd_clock_bias_ns(path.with_name(path.name + ".chk.gz"))
    common = [k for k, itow in enumerate(rec.itow_ms) if int(itow) in reference]
    assert len(common) >= 50
    ours_ns = rec.clock_bias_s[common] * 1e9
    gpsd_ns = np.array([reference[int(rec.itow_ms[k])] for k in common], dtype=float)
    np.testing.assert_allclose(ours_ns, gpsd_ns, atol=1e-6)
    assert rec.n_skipped_frames == 0


def test_nav_clock_times_are_seconds_since_first_epoch(real_data):
    rec = read_nav_clock(real_data / "receivers" / "gpsd" / "ublox-zed-f9p_hpg1.11.log.gz")
    assert rec.itow_ms.dtype == np.int64
    assert rec.t_s[0] == 0.0
    np.testing.assert_array_equal(rec.t_s, (rec.itow_ms - rec.itow_ms[0]) / 1000.0)
    assert rec.t_s.size == 655
    # clock drift is the derivative of the clock bias (between reports, the receiver does not steer)
    slope = np.diff(rec.clock_bias_s) / np.diff(rec.t_s)
    mid_drift = 0.5 * (rec.clock_drift_s_per_s[1:] + rec.clock_drift_s_per_s[:-1])
    assert np.median(np.abs(slope - mid_drift)) < 1e-9


def test_week_rollover_of_itow_is_unwrapped():
    itow = np.array([WEEK_MS - 2000, WEEK_MS - 1000, 0, 1000], dtype=np.int64)
    np.testing.assert_array_equal(unwrap_itow_ms(itow), [0, 1000, 2000, 3000])


def test_bad_checksum_frame_is_counted(real_data):
    rec = read_nav_clock(real_data / "receivers" / "ubx" / "pygpsdata-BADCK2.log")
    assert rec.n_skipped_frames == 1
    assert "checksum" in rec.skipped[0][1]
    assert rec.clock_bias_s.size == 1


@pytest.mark.parametrize("name", ["pygpsdata-BADEOF1.log", "pygpsdata-BADEOF2.log", "pygpsdata-BADEOF3.log",
                                  "pygpsdata-MIXED3BADCK.log"])
def test_broken_captures_without_nav_clock_name_the_file_and_count_corrupt_frames(real_data, name):
    path = real_data / "receivers" / "ubx" / name
    with pytest.raises(InputDataError, match="1 corrupt frame") as info:
        read_nav_clock(path)
    assert info.value.source == str(path)


def _frames(data: bytes, class_id: bytes) -> list[int]:
    """Offsets of UBX frames with the given class/id bytes."""
    offsets, i = [], data.find(b"\xb5\x62" + class_id)
    while i >= 0:
        offsets.append(i)
        i = data.find(b"\xb5\x62" + class_id, i + 1)
    return offsets


def test_corrupted_copy_counts_the_bad_checksum_and_the_truncated_frame(real_data, tmp_path):
    data = (real_data / "receivers" / "gpsd" / "navisys-gr701w.log").read_bytes()
    clean = read_nav_clock(real_data / "receivers" / "gpsd" / "navisys-gr701w.log")
    offsets = _frames(data, b"\x01\x22")  # NAV-CLOCK
    broken = bytearray(data)
    broken[offsets[10] + 6 + 4] ^= 0xFF  # flip a byte of clkB in the 11th NAV-CLOCK: the checksum fails
    cut = offsets[-1] + 10  # end the file inside the last NAV-CLOCK
    path = tmp_path / "broken.ubx"
    path.write_bytes(bytes(broken[:cut]))
    rec = read_nav_clock(path)
    assert rec.n_skipped_frames == 2
    assert rec.clock_bias_s.size == clean.clock_bias_s.size - 2
    assert int(clean.itow_ms[10]) not in set(rec.itow_ms.tolist())
    reasons = " ".join(r for _, r in rec.skipped)
    assert "checksum" in reasons


def test_file_ending_inside_a_header_is_counted(real_data, tmp_path):
    data = (real_data / "receivers" / "gpsd" / "navisys-gr701w.log").read_bytes()
    path = tmp_path / "lone_sync.ubx"
    path.write_bytes(data + b"\xb5")
    rec = read_nav_clock(path)
    assert rec.n_skipped_frames == 1
    assert rec.skipped[0] == (len(data), rec.skipped[0][1])


def test_empty_file_and_nmea_only_file_raise_naming_the_file(real_data, tmp_path):
    empty = tmp_path / "empty.ubx"
    empty.write_bytes(b"")
    with pytest.raises(InputDataError, match="empty") as info:
        read_nav_clock(empty)
    assert str(empty) in str(info.value)
    with pytest.raises(InputDataError, match="no UBX NAV-CLOCK"):
        read_nav_clock(real_data / "receivers" / "ubx" / "pygpsdata-NMEA.log")


def test_a_gzipped_capture_reads_as_the_plain_one(real_data, tmp_path):
    plain = real_data / "receivers" / "gpsd" / "navisys-gr701w.log"
    packed = tmp_path / "navisys.ubx.gz"
    packed.write_bytes(gzip.compress(plain.read_bytes()))
    ours, reference = read_nav_clock(packed), read_nav_clock(plain)
    np.testing.assert_array_equal(ours.itow_ms, reference.itow_ms)
    np.testing.assert_array_equal(ours.clock_bias_s, reference.clock_bias_s)
    assert ours.n_skipped_frames == reference.n_skipped_frames == 0


def test_an_empty_or_broken_gzip_capture_raises_naming_the_file(tmp_path):
    empty = tmp_path / "empty.ubx.gz"
    empty.write_bytes(gzip.compress(b""))
    with pytest.raises(InputDataError, match="empty"):
        read_nav_clock(empty)
    broken = tmp_path / "broken.ubx.gz"
    broken.write_bytes(gzip.compress(b"\xb5\x62" * 5000)[:30])  # gzip by its magic bytes, cut short
    with pytest.raises(InputDataError, match="broken.ubx.gz: cannot read file"):
        read_nav_clock(broken)
