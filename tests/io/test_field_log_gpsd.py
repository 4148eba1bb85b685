"""gpsd's JSON timing reports: a real gpsd (3.22, Debian) under gpsfake replaying the Resolution SMT 360
capture wrote TOFF reports whose seconds must be the capture's own 0x8F-AB seconds, as the TSIP reader
decodes them from the bytes gpsd read."""

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from chronofuse.io.field_logs import read_log
from chronofuse.io.formats import sniff_format
from chronofuse.validation import InputDataError

LOGS = Path(__file__).parents[1] / "data" / "logs"
WATCH = LOGS / "gpsd" / "gpsd-tsip-watch.json.gz"
TSIP = LOGS.parent / "receivers" / "gpsd" / "trimble-ressmt360-dr.log"
GPS_EPOCH_UNIX_S = 315_964_800


def test_a_gpsd_json_log_is_told_apart_from_its_content():
    assert sniff_format(WATCH) == "gpsd-json"


def test_each_toff_second_is_a_second_the_tsip_reader_decodes_from_the_same_capture():
    (toff,) = read_log(WATCH)
    (tsip,) = read_log(TSIP)
    assert toff.clock.startswith("TOFF /dev/pts/") and toff.time_scale == "unix-utc"
    toff_s = set((toff.t_ns // 10**9).tolist())
    tsip_utc_s = set((tsip.t_ns // 10**9 + GPS_EPOCH_UNIX_S - 18).tolist())
    assert len(toff_s) == toff.n == 27
    assert len(toff_s & tsip_utc_s) >= 25  # gpsd times its TOFF from the packet it decoded first


def test_the_toff_offset_is_gpsds_clock_minus_real_to_the_nanosecond():
    (toff,) = read_log(WATCH)
    reports = [json.loads(line) for line in gzip.open(WATCH, "rt") if '"TOFF"' in line]
    expected = [(r["clock_sec"] - r["real_sec"]) + (r["clock_nsec"] - r["real_nsec"]) * 1e-9 for r in reports]
    np.testing.assert_allclose(toff.columns["offset_s"], expected, rtol=0, atol=1e-7)
    # a replay years after the capture: the system clock is that far ahead of the receiver's seconds
    assert (toff.columns["offset_s"] > 2 * 365 * 86400 * 0.99).all()


def test_a_pps_report_as_gpsds_manual_shows_it_is_read_with_its_qerr(tmp_path):
    path = tmp_path / "pps.json"
    path.write_text(  # gpsd_json(5), the PPS example, and one with qErr (ps)
        '{"class":"PPS","device":"/dev/ttyUSB0","real_sec":1330212592,"real_nsec":343182,'
        '"clock_sec":1330212592,"clock_nsec":343184,"precision":-3}\n'
        '{"class":"PPS","device":"/dev/ttyUSB0","real_sec":1330212593,"real_nsec":0,'
        '"clock_sec":1330212593,"clock_nsec":1500,"qErr":-2300}\n')
    (pps,) = read_log(path)
    assert pps.clock == "PPS /dev/ttyUSB0"
    assert pps.columns["offset_s"].tolist() == pytest.approx([2e-9, 1.5e-6], abs=1e-15)
    assert np.isnan(pps.columns["qerr_s"][0]) and pps.columns["qerr_s"][1] == pytest.approx(-2.3e-9)


def test_a_cut_json_line_names_its_line(tmp_path):
    path = tmp_path / "cut.json"
    path.write_text('{"class":"TOFF","device":"/dev/x","real_sec":1,"real_nsec":0,"clock_sec":1,"clock_nsec":5}\n'
                    '{"class":"TOFF","device":"/dev/x","real_sec":2,"real_n\n')
    with pytest.raises(InputDataError, match=r"cut\.json:2: not a gpsd JSON report"):
        read_log(path)
