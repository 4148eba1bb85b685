"""The multi-GNSS RINEX 3 observation reader: values, missing fields, flags, compression, time systems."""

from __future__ import annotations

import gzip
import logging
import warnings

import numpy as np
import pytest

from chronofuse.io.rinex_obs import read_any_observations, read_observations
from chronofuse.io.rinex_text import rinex_bytes
from chronofuse.timescale import NS_PER_S
from chronofuse.validation import InputDataError

HEADER = """\
     3.04           OBSERVATION DATA    M                   RINEX VERSION / TYPE
TEST                                                        MARKER NAME
1234                TRIMBLE NETR9       5.45                REC # / TYPE / VERS
  3582105.2910   532589.7313  5232754.8054                  APPROX POSITION XYZ
        0.2160        0.0000        0.0000                  ANTENNA: DELTA H/E/N
G    3 C1C L1C S1C                                          SYS / # / OBS TYPES
C    2 C1I C7I                                              SYS / # / OBS TYPES
    30.000                                                  INTERVAL
  2020     6    25     0     0    0.0000000     {ts}         TIME OF FIRST OBS
                                                            END OF HEADER
"""


def _field(value: str, lli: str = " ", ssi: str = " ") -> str:
    return f"{value:>14}{lli}{ssi}"


def _write(tmp_path, body: str, *, version="3.04", ts="GPS", name="t.rnx"):
    text = HEADER.replace("3.04", version, 1).replace("{ts}", ts) + body
    path = tmp_path / name
    path.write_text(text)
    return path


BODY = (
    "> 2020 06 25 00 00  0.0000000  0  3\n"
    "G01" + _field("20000000.123", " ", "7") + _field("105000000.456", "1", "6") + _field("45.000") + "\n"
    "G02" + _field("0.000") + _field("", " ", " ") + _field("40.250") + "\n"
    "C05" + _field("38000000.500", " ", "5") + _field("38000001.500") + "\n"
    "> 2020 06 25 00 00 30.0000000  0  1\n"
    "G01" + _field("20000030.000") + "\n"
)


def test_blank_and_zero_fields_are_missing_and_flags_are_read(tmp_path):
    obs = read_observations(_write(tmp_path, BODY), observables=None)
    g1, g2 = obs.satellites.index("G01"), obs.satellites.index("G02")
    assert obs.values["C1C"][0, g1] == pytest.approx(20000000.123)
    assert np.isnan(obs.values["C1C"][0, g2])  # written as 0.000: missing (RINEX 3.05 section 5.7)
    assert np.isnan(obs.values["L1C"][0, g2])  # blank: missing
    assert obs.values["S1C"][0, g2] == pytest.approx(40.25)
    assert obs.ssi["C1C"][0, g1] == 7 and obs.lli["L1C"][0, g1] == 1 and obs.ssi["L1C"][0, g1] == 6
    assert obs.lli["C1C"][0, g1] == 0  # blank LLI is 0 (unknown)
    # a line shorter than the system's list: the observables it does not reach are missing
    assert np.isnan(obs.values["L1C"][1, g1]) and obs.values["C1C"][1, g1] == pytest.approx(20000030.0)


def test_rinex_301_beidou_band_1_is_renamed_to_the_302_b1i_code(tmp_path):
    obs = read_observations(_write(tmp_path, BODY, version="3.01"))
    c5 = obs.satellites.index("C05")
    assert "C2I" in obs.values and "C1I" not in obs.values
    assert obs.values["C2I"][0, c5] == pytest.approx(38000000.5)


def test_rinex_304_keeps_c1i_as_it_is_named(tmp_path):
    obs = read_observations(_write(tmp_path, BODY, version="3.04"))
    assert "C1I" in obs.values and "C2I" not in obs.values


def test_a_bdt_file_is_put_on_gps_time(tmp_path):
    gps = read_observations(_write(tmp_path, BODY, name="g.rnx"))
    bdt = read_observations(_write(tmp_path, BODY, ts="BDT", name="b.rnx"))
    assert (bdt.gps_ns - gps.gps_ns == 14 * NS_PER_S).all()


def test_events_and_cycle_slip_records_are_not_epochs_and_damage_is_counted(tmp_path):
    body = BODY + (
        "> 2020 06 25 00 01 00.0000000  4  1\n"
        "                                                            COMMENT\n"
        "> 2020 06 25 00 00 30.0000000  6  1\n"
        "G01" + _field("1.000") + "\n"
        "> 2020 06 25 00 01 30.0000000  0  2\n"
        "G01" + _field("20000090.000") + "\n"
    )  # the last record declares two satellites and holds one: cut short
    obs = read_observations(_write(tmp_path, body))
    assert obs.gps_ns.size == 2 and obs.n_event_records == 2 and obs.n_unreadable_epochs == 1
    assert not np.isclose(obs.values["C1C"], 1.0).any()


def test_a_power_failure_epoch_is_kept_with_its_flag(tmp_path):
    obs = read_observations(_write(tmp_path, BODY.replace("30.0000000  0  1", "30.0000000  1  1")))
    assert obs.gps_ns.size == 2 and list(obs.epoch_flag) == [0, 1]


def test_not_an_observation_file_is_refused_naming_it(tmp_path):
    nav = tmp_path / "n.rnx"
    nav.write_text("     3.04           N: GNSS NAV DATA    M                   RINEX VERSION / TYPE\n")
    with pytest.raises(InputDataError, match="not a RINEX observation file") as err:
        read_observations(nav)
    assert "n.rnx" in str(err.value)


def test_hatanaka_gzip_and_plain_copies_of_a_real_station_read_the_same(tmp_path, igs_stations):
    station = igs_stations["BOR1"]
    plain = tmp_path / "bor1.rnx"
    plain.write_bytes(rinex_bytes(station.obs_path))
    zipped = tmp_path / "bor1.rnx.gz"
    zipped.write_bytes(gzip.compress(plain.read_bytes(), compresslevel=1))
    a = read_observations(station.obs_path)
    for other in (read_observations(plain), read_observations(zipped)):
        assert other.satellites == a.satellites and (other.gps_ns == a.gps_ns).all()
        for code in a.values:
            np.testing.assert_array_equal(other.values[code], a.values[code])
    assert a.gps_ns.size == 2880 and a.header.receiver == "TRIMBLE NETR9"


def test_our_reader_agrees_with_georinex_value_by_value_on_a_real_hour(tmp_path, igs_stations):
    import georinex

    station = igs_stations["ESBC"]
    lines = rinex_bytes(station.obs_path).splitlines(keepends=True)
    epochs = [i for i, line in enumerate(lines) if line.startswith(b">")]
    hour = tmp_path / "esbc_hour.rnx"
    hour.write_bytes(b"".join(lines[:epochs[120]]))  # header and the first hour (120 epochs at 30 s)
    ours = read_observations(hour, systems=("G", "E", "C"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        logging.disable(logging.CRITICAL)
        try:
            theirs = georinex.load(hour, use={"G", "E", "C"}, meas=["C1C", "C2I", "C5Q"])
        finally:
            logging.disable(logging.NOTSET)
    sats = [str(s) for s in theirs.sv.values]
    assert ours.gps_ns.size == theirs.sizes["time"] == 120
    compared = 0
    for code in ("C1C", "C2I", "C5Q"):
        ref = theirs[code].transpose("time", "sv").values.copy()
        ref[ref == 0.0] = np.nan  # georinex keeps a 0.000 field as 0 m; RINEX defines it as missing
        for j, sat in enumerate(sats):
            col = ref[:, j]
            if sat not in ours.satellites:
                assert np.isnan(col).all()
                continue
            np.testing.assert_allclose(ours.values[code][:, ours.satellites.index(sat)], col, rtol=0, atol=1e-6)
            compared += int(np.isfinite(col).sum())
    assert compared > 5000


def test_a_rinex_2_file_reads_through_georinex_with_rinex_3_codes(real_data):
    obs = read_any_observations(real_data / "receivers" / "rinex" / "rtklib" / "07590920.05o")
    assert obs.gps_ns.size == 120 and {"C1C", "C2W"} <= set(obs.values)
    assert obs.header.receiver == "TRIMBLE 5700" and obs.header.approx_position_m is not None
