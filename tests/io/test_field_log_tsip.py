"""Trimble TSIP timing packets from a real Resolution SMT 360 capture, checked against gpsd's own decoding of it."""

import json
import time
from pathlib import Path

import numpy as np
import pytest

from chronofuse.io.field_logs import read_log, series_record
from chronofuse.io.formats import sniff_format
from chronofuse.io.tsip import read_tsip, tsip_packets
from chronofuse.timescale import NS_PER_S

DATA = Path(__file__).parents[1] / "data" / "receivers" / "gpsd"  # gpsd's regression captures
LOG = DATA / "trimble-ressmt360-dr.log"
GPS_EPOCH_UNIX_S = 315_964_800
LEAP_S = 18  # the capture's own leap second count (gpsd's TPV "leapseconds")


def _gpsd_timing_reports():
    """gpsd's TPV reports that carry the 0x8F-AC decode (temperature, clock offset), first per second."""
    out = {}
    with open(DATA / "trimble-ressmt360-dr.log.chk") as fh:
        for line in fh:
            if not line.startswith("{"):  # the check file's own "#" header lines
                continue
            r = json.loads(line)
            if r.get("class") == "TPV" and "temp" in r:
                out.setdefault(r["time"][:19], r)
    return out


def test_a_tsip_capture_is_told_apart_from_its_bytes():
    assert sniff_format(LOG) == "tsip"


def test_every_supplemental_timing_packet_agrees_with_gpsd_on_time_temperature_and_clock_offset():
    (s,) = read_log(LOG)
    gpsd = _gpsd_timing_reports()
    assert s.n == 27 and len(gpsd) >= s.n
    for t_ns, temp, freq in zip(s.t_ns, s.columns["temperature_c"], s.columns["freq"]):
        utc = time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(int(t_ns) // NS_PER_S + GPS_EPOCH_UNIX_S - LEAP_S))
        ref = gpsd[utc]
        assert round(float(temp), 3) == pytest.approx(ref["temp"], abs=1e-9)
        assert int(freq * 1e9) == ref["clockbias"]  # gpsd prints the float's integer part


def test_the_antenna_open_and_no_satellite_seconds_are_marked_not_ok_and_read_as_alarms():
    (s,) = read_log(LOG)
    alarms = s.columns["minor_alarms"].astype(int)
    assert ((alarms & 0x02) != 0).sum() > 0  # the capture's dead-reckoning test pulled the antenna
    np.testing.assert_array_equal(s.ok, (alarms & 0x08) == 0)
    assert s.events[0][1] == "disciplining mode normal"


def test_a_tsip_series_becomes_a_one_second_frequency_record():
    (s,) = read_log(LOG)
    rec = series_record(s, kind="freq")
    assert rec.rate_hz == pytest.approx(1.0) and rec.kind == "freq" and rec.n_gaps == 0
    assert np.nanmean(rec.values) == pytest.approx(-2.13e-7, abs=1e-8)


def test_stuffed_dle_bytes_are_unstuffed_and_a_frame_without_its_end_is_not_a_packet():
    frame = bytes([0x10, 0x8F, 0xAB, 0x10, 0x10, 0x01, 0x10, 0x03])
    assert list(tsip_packets(frame + frame[:-2])) == [(0, 0x8F, bytes([0xAB, 0x10, 0x01]))]


def test_a_truncated_timing_packet_is_noted_not_read(tmp_path):
    cut = LOG.read_bytes().replace(b"\x10\x8f\xac", b"\x10\x8f\xac\x10\x03", 1)  # the first 0x8F-AC ends after its subcode
    path = tmp_path / "cut.tsip"
    path.write_bytes(cut)
    (s,) = read_tsip(path)
    assert s.n == 26 and any("0x8F-AC of 1 bytes" in note for note in s.notes)


def _frame(body: bytes) -> bytes:
    """A TSIP frame of ``body`` (its first byte the packet id): DLE, the bytes with DLE doubled, DLE ETX."""
    return b"\x10" + body.replace(b"\x10", b"\x10\x10") + b"\x10\x03"


def _timing_pair(tow: int, disc_mode: int, dac_v: float, temp: float, holdover: int) -> bytes:
    import struct

    ab = struct.pack(">BBIHhBBBBBBH", 0x8F, 0xAB, tow, 2300, 18, 0x03, 0, 0, 0, 4, 2, 2024)
    ac = struct.pack(">BBBBBIHHBBBBffIffdddff", 0x8F, 0xAC, 0, disc_mode, 100, holdover, 0, 0, 0, 0, 0, 0,
                     12.5, -3.25, 0x10101010, dac_v, temp, 0.9, -1.3, 100.0, 0.0, 0.0)
    return _frame(ab) + _frame(ac)


def test_a_thunderbolt_holdover_is_decoded_with_its_dac_voltage_and_temperature(tmp_path):
    # 0x8F-AC laid out as the Thunderbolt user guide (and gpsd's decoder) give it; the DAC value's 0x10 bytes
    # are sent doubled, as TSIP stuffs them
    path = tmp_path / "thunderbolt.tsip"
    path.write_bytes(b"".join(_timing_pair(100 + k, 0 if k < 3 else 2, 1.25 + 0.01 * k, 40.0 + k, 0 if k < 3 else k)
                              for k in range(6)))
    assert sniff_format(path) == "tsip"
    (s,) = read_tsip(path)
    assert s.n == 6 and s.t_ns[0] == (2300 * 604800 + 100) * NS_PER_S
    np.testing.assert_allclose(s.columns["dac_v"], 1.25 + 0.01 * np.arange(6), rtol=1e-6)
    np.testing.assert_allclose(s.columns["temperature_c"], 40.0 + np.arange(6))
    assert s.columns["dac_value"][0] == 0x10101010
    assert s.columns["pps_offset_s"][0] == pytest.approx(12.5e-9) and s.columns["freq"][0] == pytest.approx(-3.25e-9)
    assert s.ok.tolist() == [True, True, True, False, False, False]
    assert [text for _, text in s.events] == ["disciplining mode normal", "disciplining mode auto holdover"]
    assert s.columns["holdover_s"][-1] == 5
