"""Sniffing a file's format from its first bytes, on the real captures of each kind."""

import gzip

import pytest

from chronofuse.io.formats import FORMATS, capture_format, is_gzip, open_data, sniff_format
from chronofuse.validation import InputDataError


@pytest.mark.parametrize(
    "relative, kind",
    [
        ("receivers/gpsd/navisys-gr701w.log", "ubx"),
        ("receivers/gpsd/ublox-zed-f9p_hpg1.11.log.gz", "ubx"),
        ("receivers/ubx/pygpsdata-MIXED3BADCK.log", "ubx"),
        ("receivers/gpsd/ublox-zed-f9t-ubx_nmea_l5.log", "ubx"),
        ("receivers/gpsd/ac12.log", "nmea"),
        ("receivers/gpsd/beidou-gb.log", "nmea"),
        ("receivers/gpsd/st-teseo-liv4f.log", "nmea"),
        ("receivers/ubx/pygpsdata-NMEA.log", "nmea"),
        ("receivers/rinex/rtklib/07590920.05o", "rinex-obs"),
        ("receivers/rinex/georinex/demo3.10o", "rinex-obs"),
        ("receivers/rinex/rtklib/07590920.05n", "rinex-nav"),
        ("stability/phasedat/PHASE.DAT", "csv"),
        ("stability/gps/gps_1pps_phase_data.txt.gz", "csv"),
    ],
)
def test_each_shipped_capture_is_told_apart_by_its_first_bytes(real_data, relative, kind):
    assert kind in FORMATS
    assert sniff_format(real_data / relative) == kind


def test_a_hatanaka_compressed_file_is_observations_whatever_its_type_letter(tmp_path):
    path = tmp_path / "x.crx"
    path.write_text("1.0                 COMPACT RINEX FORMAT                    CRINEX VERS   / TYPE\n")
    assert sniff_format(path) == "rinex-obs"


def test_missing_empty_folder_and_broken_gzip_inputs_raise_naming_the_path(tmp_path):
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    broken = tmp_path / "broken.csv"
    broken.write_bytes(gzip.compress(b"t_s,clock_bias_s\n" * 200)[:40])  # gzip magic, stream cut short
    for path, fragment in ((tmp_path / "none.csv", "no such file"), (tmp_path, "is a directory"),
                           (empty, "empty file"), (broken, "cannot read file")):
        with pytest.raises(InputDataError, match=fragment) as info:
            sniff_format(path)
        assert info.value.source == str(path)
    assert sniff_format(_gzipped(tmp_path / "ok.csv.gz", b"t_s,clock_bias_s\n0,1e-9\n")) == "csv"


def _gzipped(path, data: bytes):
    path.write_bytes(gzip.compress(data))
    return path


def test_gzip_is_told_by_its_magic_bytes_not_by_the_file_name(real_data, tmp_path):
    nmea = (real_data / "receivers/gpsd/ac12.log").read_bytes()
    ubx = gzip.decompress((real_data / "receivers/gpsd/ublox-zed-f9p_hpg1.11.log.gz").read_bytes())
    packed_nmea = tmp_path / "nmea.log"  # gzip content, no .gz suffix
    packed_nmea.write_bytes(gzip.compress(nmea))
    plain_ubx = tmp_path / "capture.ubx.gz"  # a .gz suffix on plain bytes
    plain_ubx.write_bytes(ubx)
    assert sniff_format(packed_nmea) == "nmea" and is_gzip(packed_nmea)
    assert sniff_format(plain_ubx) == "ubx" and not is_gzip(plain_ubx)
    with open_data(packed_nmea) as fh:
        assert fh.read() == nmea


def test_gpsd_comment_headers_do_not_hide_nmea_and_text_tables_stay_text(tmp_path):
    gga = b"$GPGGA,193221.00,2037.72792,N,08704.08478,W,1,04,1.7,-30.40,M,-13.9,M,,*7D\r\n"
    log = tmp_path / "receiver.log"
    log.write_bytes(b"# Name: a receiver\n# Chipset: x\n#\n" + gga * 3)
    assert sniff_format(log) == "nmea" and capture_format(log) == "nmea"
    table = tmp_path / "bias.csv"
    table.write_bytes(b"# from a counter\nt_s,clock_bias_s\n0,1e-9\n1,2e-9\n")
    assert sniff_format(table) == "csv" and capture_format(table) is None
    # one stray sentence in a table is not an NMEA recording
    table.write_bytes(b"t_s,clock_bias_s\n" + gga + b"0,1e-9\n1,2e-9\n2,3e-9\n")
    assert sniff_format(table) == "csv"
    assert capture_format(tmp_path / "missing.log") is None
