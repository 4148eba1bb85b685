"""Sniffing a file's format from its first bytes, on the real captures of each kind."""

import gzip

import pytest

from chronofuse.io.formats import FORMATS, sniff_format
from chronofuse.validation import InputDataError


@pytest.mark.parametrize(
    "relative, kind",
    [
        ("receivers/gpsd/navisys-gr701w.log", "ubx"),
        ("receivers/gpsd/ublox-zed-f9p_hpg1.11.log.gz", "ubx"),
        ("receivers/ubx/pygpsdata-MIXED3BADCK.log", "ubx"),
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
    broken = tmp_path / "broken.csv.gz"
    broken.write_bytes(b"plain text, not gzip")
    for path, fragment in ((tmp_path / "none.csv", "no such file"), (tmp_path, "is a directory"),
                           (empty, "empty file"), (broken, "cannot read file")):
        with pytest.raises(InputDataError, match=fragment) as info:
            sniff_format(path)
        assert info.value.source == str(path)
    assert sniff_format(_gzipped(tmp_path / "ok.csv.gz", b"t_s,clock_bias_s\n0,1e-9\n")) == "csv"


def _gzipped(path, data: bytes):
    path.write_bytes(gzip.compress(data))
    return path
