"""Our NMEA/UBX readers against gpsd's own decoding of its regression captures (``*.log.chk``).

For every capture in ``receivers/gpsd`` that comes with gpsd's expected output and holds NMEA or UBX we
decode, gpsd's TPV epochs (time, mode) and SKY DOPs are compared with ours epoch by epoch. Where gpsd
and we differ by gpsd's choice, the count and the reason are in :data:`GPSD_CHOICES`; the test asserts
the counts exactly, so a new disagreement (or a fixed one) shows. Each DOP disagreement is given, value
by value, the first reason of :mod:`gpsd_dop_reasons` that reproduces gpsd's value (or ``unexplained``);
``python tests/io/gpsd_dop_reasons.py`` prints the totals.

Captures in another receiver's binary protocol (or NMEA from a talker we do not read) are named in
:data:`UNDECODABLE` with the protocol; every other capture must decode to epochs, so a reader regression
fails here instead of showing as a skip.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from chronofuse.io.inspect import read_bytes, read_capture
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_ns_to_datetime64

from .conftest import receivers_dir
from .gpsd_dop_reasons import (GPSD_GEOMETRY, LATER_EPOCH, NEXT_BURST, OTHER_MESSAGE, PREVIOUS_BURST, REASONS,
                               REPLACED_IN_CYCLE, TOLERANCE, UNEXPLAINED, burst_dops, classify)

_FIX_TRANSITION = ("gpsd reports the mode of the last sentence of a burst that mixes fix and no-fix "
                   "reports (fix lost or regained); we report the highest mode the burst announces")
_WEEK_SHIFT = ("gpsd moved these dates 1024 weeks later (its rollover guard assumes no date before its "
               "build); we keep the receiver's date unless given a reference epoch: read with gpsd's "
               "date as reference, every time agrees")
_HNR = "gpsd also reports the 10 Hz HNR-PVT (high-rate dead-reckoning) epochs; we decode NAV epochs only"
_LEAP_DEFAULT = ("gpsd labels the first epoch with its compiled-in GPS-UTC (18 s) before the receiver's "
                 "NAV-TIMEGPS leap count (15 s / 14 s) arrives; we use the receiver's count")

_ZDA_AHEAD = ("this receiver stamps ZDA one second ahead of its burst's GGA/RMC; gpsd gives the ZDA time the "
              "last fix mode it saw, our ZDA-only epoch has no fix report (mode 0, unknown)")

_TIME_BACK = ("the receiver's time jumps back at its cold boot (its clock corrected); gpsd reports every TPV in "
              "arrival order, we leave out an epoch that comes behind one already released by more than the reorder "
              "buffer holds (io/arrival.py), counted as late, live and batch alike")

#: file -> {"missing": (count, reason), "mode": (count, reason), "dop": {reason: count}, "reference": True}
#: (the DOP reasons are the keys of gpsd_dop_reasons.REASONS, each checked value by value)
GPSD_CHOICES: dict[str, dict] = {
    "ac12.log": {"mode": (5, _ZDA_AHEAD)},
    "ac12_binary.log": {"mode": (4, _ZDA_AHEAD)},
    "eXplorist210.log": {"mode": (2, _FIX_TRANSITION)},
    "garmin25lp.log": {"mode": (1, _FIX_TRANSITION)},
    "bt451.log": {"missing": (5, _TIME_BACK)},
    "gp-320fw-2019-04-07-coldboot.log": {
        "missing": (8, "7 epochs: " + _TIME_BACK + "; 1: gpsd dates this epoch from a ZDA of the next burst; the RMC "
                       "of its own burst has a bad checksum and is not trusted"),
        "mode": (1, _FIX_TRANSITION)},
    "hemi.log": {"mode": (15, _FIX_TRANSITION)},
    "meinberg-gps164.log": {"mode": (1, _FIX_TRANSITION)},
    "quectel.log": {"mode": (1, _FIX_TRANSITION)},
    "sl869.log": {"mode": (1, _FIX_TRANSITION)},
    "tomtom-mkII.log": {"mode": (1, _FIX_TRANSITION)},
    "unicore-um621.log": {"mode": (1, _FIX_TRANSITION)},
    "ublox-lea-4h.log": {"mode": (2, _FIX_TRANSITION)},
    "navisys-gr701w.log": {"mode": (3, "fix lost: gpsd keeps the 2-D mode of NAV-SOL while NAV-PVT says no fix")},
    "neo-m8n.log": {"reference": True},
    "rst39.log": {"reference": True},
    "tcp-torture.log": {"reference": True},
    "ublox-neo-m8l.log": {"missing": (171, _HNR)},
    "ublox-neo-m8u-hnr.log": {"missing": (11, _HNR)},
    "ublox-lea-4t.log": {"missing": (1, _LEAP_DEFAULT)},
    "ublox-aek-4t.log": {"missing": (1, _LEAP_DEFAULT)},
}
# DOP disagreements (values off by more than TOLERANCE), per file: reason -> count, each value given the first
# reason of gpsd_dop_reasons.classify that reproduces gpsd's value (UNEXPLAINED: none does)
_DOP_REASONS = {
    "ch-4701.log": {GPSD_GEOMETRY: 4},
    "ch-4711.log": {NEXT_BURST: 2, PREVIOUS_BURST: 2},
    "garmin17n.log": {REPLACED_IN_CYCLE: 1},
    "iTrek.log": {GPSD_GEOMETRY: 2},
    "isync.log": {NEXT_BURST: 3},
    "navisys-gr701w.log": {NEXT_BURST: 8},
    "navisys-gr8013.log": {NEXT_BURST: 10},
    "pharos-360.log": {NEXT_BURST: 1},
    "quectel-l76k-dual.log": {REPLACED_IN_CYCLE: 3, NEXT_BURST: 2},
    "rx210.log": {PREVIOUS_BURST: 2},
    "ublox-8-time.log": {LATER_EPOCH: 1},
    "ublox-aek-4t.log": {NEXT_BURST: 1},
    "ublox-neo-m8n.log": {GPSD_GEOMETRY: 5},
    "ublox-neo-m8t.log": {LATER_EPOCH: 3, NEXT_BURST: 3, REPLACED_IN_CYCLE: 1},
    "ublox-zed-f9p-hp.log": {LATER_EPOCH: 6, NEXT_BURST: 4},
    "ublox-zed-f9r.log": {NEXT_BURST: 24},
    "ublox8-uniqid-monhw.log": {GPSD_GEOMETRY: 4, UNEXPLAINED: 2, PREVIOUS_BURST: 2},
}
for _name, _reasons in _DOP_REASONS.items():
    GPSD_CHOICES.setdefault(_name, {})["dop"] = _reasons

_DOPS = ("gdop", "pdop", "hdop", "vdop", "tdop")

_SIRF = "SiRF binary protocol"
_TSIP = "Trimble TSIP binary protocol"
_ONCORE = "Motorola Oncore binary protocol"
_GREIS = "Javad GREIS binary protocol"
#: Captures gpsd decodes and we do not, each with the reason (its header's receiver and protocol). Each
#: holds no NMEA sentence of a talker we read and no UBX message; a capture listed here that starts to
#: decode fails too, so the list stays true.
UNDECODABLE: dict[str, str] = {
    "bu303-climbing.log": _SIRF, "bu303-moving.log": _SIRF, "bu303-nofix.log": _SIRF,
    "bu303-stillfix.log": _SIRF, "bu303b-nofix.log": _SIRF, "sirf2.log": _SIRF, "sirfstarv.log": _SIRF,
    "ublox-sirf1.log": _SIRF + " (a SiRF-I u-blox)",
    "garmin18x-bin.log": "Garmin binary protocol",
    "geostar-geos1m-binary.log": "GeoStar binary protocol",
    "greis-binary.log": _GREIS, "greis-raw-2m.log": _GREIS, "greis-reset.log": _GREIS, "greis-test2.log": _GREIS,
    "humminbird-M37.log": "NMEA from talker IN (integrated instrumentation), not a GNSS talker we read",
    "italk-binary.log": "Fastrax iTalk binary protocol",
    "navcom.log": "Navcom binary protocol",
    "oncore-binary-pos-hold.log": _ONCORE, "oncore-binary.log": _ONCORE, "oncore-m12.log": _ONCORE,
    "quectel-l76k-binary.log": "CASIC binary protocol (Quectel L76K)",
    "skytraq-A8.log": "SkyTraq binary protocol", "skytraq-bin.log": "SkyTraq binary protocol",
    "superstar2.log": "NovAtel SuperStar II binary protocol",
    "trimble-lassen_iq-3dfix.log": _TSIP, "trimble-lassen_iq-playacar.log": _TSIP, "trimble-lassen_iq.log": _TSIP,
    "trimble-lasseniq-bin2d.log": _TSIP, "trimble-res720-dr.log": _TSIP, "trimble-res720.log": _TSIP,
    "trimble-ressmt360-dr.log": _TSIP, "trimble-smt-360.log": _TSIP, "trimble-smtx-dr.log": _TSIP,
    "trimble-smtx.log": _TSIP,
    "zodiac.log": "Rockwell Zodiac (Jupiter) binary protocol",
}



def gpsd_expected(chk: Path) -> tuple[dict, dict]:
    """gpsd's TPV mode per time label (the last TPV of each time) and its SKY reports per time, in order
    (the last of a time is the one compared).

    A SKY without a time belongs to the NEXT TPV time: gpsd reports an NMEA epoch's TPV when its cycle
    ends, so the SKYs it sends while a burst's GSA/GSV arrive come before that burst's TPV (pairing them
    with the TPV before them gave 750 false "disagreements", each the next burst's DOP). SKYs after the
    last TPV belong to the last time."""
    tpv: dict[str, int] = {}
    sky: dict[str, list] = {}
    pending: list = []
    last = None
    for line in chk.read_text(errors="replace").splitlines():
        if line.startswith('{"class":"TPV"'):
            doc = json.loads(line)
            if "time" in doc:
                tpv[doc["time"]] = doc["mode"]
                last = doc["time"]
                if pending:
                    sky.setdefault(last, []).extend(pending)
                    pending = []
        elif line.startswith('{"class":"SKY"'):
            doc = json.loads(line)
            if "time" in doc:
                sky.setdefault(doc["time"], []).append(doc)
            else:
                pending.append(doc)
    if pending and last is not None:
        sky.setdefault(last, []).extend(pending)
    return tpv, sky


def _oracle_files() -> list[str]:
    names = []
    for log in sorted((receivers_dir() / "gpsd").glob("*.log")):
        chk = log.with_name(log.name + ".chk")
        if chk.is_file() and '"class":"TPV"' in chk.read_text(errors="replace") and '"time":' in chk.read_text(
                errors="replace"):
            names.append(log.name)
    return names


ORACLE_FILES = _oracle_files()


def compare_with_gpsd(log: Path) -> dict:
    """Counts of gpsd epochs we lack, mode disagreements and DOP disagreements for one capture."""
    tpv, sky = gpsd_expected(log.with_name(log.name + ".chk"))
    reference = None
    if GPSD_CHOICES.get(log.name, {}).get("reference"):
        first = np.datetime64(next(iter(tpv)).rstrip("Z"), "ns")
        reference = int(datetime64_to_gps_ns(first))
    capture = read_capture(log, reference_gps_ns=reference)
    labels = [s + "Z" for s in np.datetime_as_string(gps_ns_to_datetime64(capture.utc_ns()), unit="ms")]
    index = {label: i for i, label in enumerate(labels)}
    rows = capture.rows
    missing = [t for t in tpv if t not in index]
    mode_bad = [t for t in tpv if t in index and int(rows["fix_mode"][index[t]]) != tpv[t]]
    dop_compared, reasons = 0, Counter()
    bursts = burst_dops(log) if "nmea" in capture.protocols else {}
    # NMEA sends no GDOP/TDOP: gpsd computes its own and so do we (geometry_dops, checked against the
    # receivers' own PDOP in test_receiver_readers); the receivers' DOPs are what is compared here
    names = ("pdop", "hdop", "vdop") if capture.protocols == ("nmea",) else _DOPS
    sky_epochs = sorted(index[t] for t in sky if t in index)
    for t, skies in sky.items():
        if t not in index:
            continue
        i, doc = index[t], skies[-1]
        k = sky_epochs.index(i)
        window = (sky_epochs[k - 1] if k > 0 else i - 1, sky_epochs[k + 1] if k + 1 < len(sky_epochs) else i + 1)
        for name in names:
            ours = float(rows[name][i])
            if name in doc and np.isfinite(ours) and ours < 99.0:
                dop_compared += 1
                if abs(doc[name] - ours) > TOLERANCE:
                    reasons[classify(name, doc[name], rows[name], i, skies, bursts.get(t[11:23], []),
                                             window)] += 1
    return {"gpsd_epochs": len(tpv), "missing": len(missing), "mode": len(mode_bad),
            "dop": sum(reasons.values()), "dop_reasons": dict(reasons), "dop_compared": dop_compared,
            "protocols": capture.protocols}


def test_the_oracle_covers_the_nmea_and_ubx_captures_with_a_reference_decoding():
    assert len(ORACLE_FILES) >= 150


@pytest.mark.parametrize("name", sorted(UNDECODABLE))
def test_a_capture_listed_as_undecodable_decodes_to_nothing(receivers, name):
    capture = read_capture(receivers / "gpsd" / name)
    assert capture.protocols == () and capture.n_epochs == 0, f"{name} decodes now: take it off UNDECODABLE"


@pytest.mark.parametrize("name", [n for n in ORACLE_FILES if n not in UNDECODABLE])
def test_time_mode_and_dops_agree_with_gpsd_epoch_by_epoch(receivers, name):
    result = compare_with_gpsd(receivers / "gpsd" / name)
    assert result["protocols"], f"{name}: decoded to nothing, and it is not listed in UNDECODABLE"
    choices = GPSD_CHOICES.get(name, {})
    for key in ("missing", "mode"):
        expected = choices.get(key, (0, ""))[0]
        assert result[key] == expected, f"{name}: {key} {result[key]} != listed {expected} ({result})"
    assert result["dop_reasons"] == choices.get("dop", {}), f"{name}: DOP disagreements by reason ({result})"


def test_every_listed_choice_names_a_capture_of_the_oracle():
    assert set(GPSD_CHOICES) <= set(ORACLE_FILES)


def test_every_capture_listed_as_undecodable_is_a_capture_of_the_oracle_with_no_listed_choice():
    assert set(UNDECODABLE) <= set(ORACLE_FILES)
    assert not set(UNDECODABLE) & set(GPSD_CHOICES)


def test_every_listed_dop_disagreement_has_one_of_the_checked_reasons():
    listed = [reason for choice in GPSD_CHOICES.values() for reason in choice.get("dop", {})]
    assert listed and set(listed) <= set(REASONS)


def test_the_dop_classifier_finds_the_next_burst_and_says_unexplained_otherwise():
    ours = np.array([1.2, 1.5, 1.9])
    assert classify("pdop", 1.9, ours, 1, [{"pdop": 1.9}], []) == NEXT_BURST
    assert classify("pdop", 1.2, ours, 1, [{"pdop": 1.2}], []) == PREVIOUS_BURST
    assert classify("hdop", 0.9, ours, 1, [{"hdop": 0.9}], [{"pdop": 1.5, "hdop": 1.5}, {"hdop": 0.9}]) == OTHER_MESSAGE
    assert classify("pdop", 7.0, ours, 1, [{"pdop": 1.5}, {"pdop": 7.0}], []) == REPLACED_IN_CYCLE
    assert classify("pdop", 7.0, ours, 1, [{"pdop": 7.0}], []) == UNEXPLAINED


def test_the_dop_classifier_looks_at_later_epochs_only_up_to_gpsds_next_sky_time():
    ours = np.array([1.2, 1.5, 1.6, 1.7, 1.9])
    assert classify("pdop", 1.9, ours, 1, [{"pdop": 1.9}], [], window=(0, 4)) == LATER_EPOCH
    assert classify("pdop", 1.9, ours, 1, [{"pdop": 1.9}], [], window=(0, 3)) == UNEXPLAINED
    assert classify("pdop", 1.2, ours, 3, [{"pdop": 1.2}], [], window=(0, 4)) == PREVIOUS_BURST
    assert classify("pdop", 1.2, ours, 3, [{"pdop": 1.2}], [], window=(2, 4)) == UNEXPLAINED


def test_week_rollover_dates_move_by_exactly_1024_weeks_with_a_reference(receivers):
    log = receivers / "gpsd" / "neo-m8n.log"
    as_sent = read_capture(log)
    tpv, _ = gpsd_expected(log.with_name(log.name + ".chk"))
    reference = int(datetime64_to_gps_ns(np.datetime64(next(iter(tpv)).rstrip("Z"), "ns")))
    moved = read_capture(log, reference_gps_ns=reference)
    shift = moved.utc_ns() - as_sent.utc_ns()
    assert np.all(shift == 1024 * 604_800 * NS_PER_S)


def test_a_gsa_with_zero_dops_gives_no_dop_and_a_real_one_is_kept():
    # CH-4711 lines as sent: a 2-D fix with its DOPs, then a no-fix burst whose GSA fills the DOPs with 00.0
    fix = (b"$GNGGA,135651.997,5543.0328,N,03724.7198,E,1,06,01.8,165.6,M,14.6,M,,*73\r\n"
           b"$GNRMC,135651.997,A,5543.0328,N,03724.7198,E,00.00,129.5,051209,,,A*79\r\n"
           b"$GNGSA,A,2,19,27,,,,,,,,,,,02.1,01.8,00.9*13\r\n")
    no_fix = (b"$GPGGA,135700.997,5543.0322,N,03724.7208,E,0,,,165.6,M,14.6,M,,*78\r\n"
              b"$GPRMC,135700.997,V,5543.0322,N,03724.7208,E,00.79,159.0,051209,,,N*76\r\n"
              b"$GPGSA,A,1,,,,,,,,,,,,,00.0,00.0,00.0*00\r\n")
    rows = read_bytes([fix + no_fix]).rows
    assert rows["gps_ns"].size == 2
    assert [rows[name][0] for name in ("pdop", "hdop", "vdop")] == [2.1, 1.8, 0.9]
    assert all(np.isnan(rows[name][1]) for name in ("pdop", "hdop", "vdop"))


def test_a_sky_without_a_time_belongs_to_the_tpv_that_follows_it(tmp_path):
    chk = tmp_path / "x.log.chk"
    chk.write_text("\n".join([
        '{"class":"TPV","mode":3,"time":"2020-01-01T00:00:01.000Z"}',
        '{"class":"SKY","pdop":2.0}',
        '{"class":"SKY","pdop":2.5}',
        '{"class":"TPV","mode":3,"time":"2020-01-01T00:00:02.000Z"}',
        '{"class":"SKY","time":"2020-01-01T00:00:02.000Z","pdop":3.0}',
        '{"class":"SKY","pdop":3.5}',
    ]) + "\n")
    tpv, sky = gpsd_expected(chk)
    assert tpv == {"2020-01-01T00:00:01.000Z": 3, "2020-01-01T00:00:02.000Z": 3}
    assert "2020-01-01T00:00:01.000Z" not in sky
    assert [s["pdop"] for s in sky["2020-01-01T00:00:02.000Z"]] == [2.0, 2.5, 3.0, 3.5]
