"""Our NMEA/UBX readers against gpsd's own decoding of its regression captures (``*.log.chk``).

For every capture in ``receivers/gpsd`` that comes with gpsd's expected output and holds NMEA or UBX we
decode, gpsd's TPV epochs (time, mode) and SKY DOPs are compared with ours epoch by epoch. Where gpsd
and we differ by gpsd's choice, the count and the reason are in :data:`GPSD_CHOICES`; the test asserts
the counts exactly, so a new disagreement (or a fixed one) shows.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from chronofuse.io.inspect import read_capture
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_ns_to_datetime64

from .conftest import receivers_dir

_FIX_TRANSITION = ("gpsd reports the mode of the last sentence of a burst that mixes fix and no-fix "
                   "reports (fix lost or regained); we report the highest mode the burst announces")
_DOP_RECOMPUTED = ("gpsd's SKY DOPs here are its own, recomputed from the satellites' azimuth/elevation "
                   "and used flags (gpsd's fill_dop), or taken from a GSA of the next burst; ours are the "
                   "receiver's GSA / NAV-DOP values as sent")
_WEEK_SHIFT = ("gpsd moved these dates 1024 weeks later (its rollover guard assumes no date before its "
               "build); we keep the receiver's date unless given a reference epoch: read with gpsd's "
               "date as reference, every time agrees")
_HNR = "gpsd also reports the 10 Hz HNR-PVT (high-rate dead-reckoning) epochs; we decode NAV epochs only"
_LEAP_DEFAULT = ("gpsd labels the first epoch with its compiled-in GPS-UTC (18 s) before the receiver's "
                 "NAV-TIMEGPS leap count (15 s / 14 s) arrives; we use the receiver's count")

_ZDA_AHEAD = ("this receiver stamps ZDA one second ahead of its burst's GGA/RMC; gpsd gives the ZDA time the "
              "last fix mode it saw, our ZDA-only epoch has no fix report (mode 0, unknown)")

#: file -> {"missing": (count, reason), "mode": (count, reason), "dop": (count, reason), "reference": True}
GPSD_CHOICES: dict[str, dict] = {
    "ac12.log": {"mode": (5, _ZDA_AHEAD)},
    "ac12_binary.log": {"mode": (4, _ZDA_AHEAD)},
    "eXplorist210.log": {"mode": (2, _FIX_TRANSITION)},
    "garmin25lp.log": {"mode": (1, _FIX_TRANSITION)},
    "gp-320fw-2019-04-07-coldboot.log": {
        "missing": (1, "gpsd dates this epoch from a ZDA of the next burst; the RMC of its own burst has a bad "
                       "checksum and is not trusted"),
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
# DOP disagreements (count of DOP values off by more than 0.005), all for the one reason above
_DOP_COUNTS = {
    "ais-nmea.log": 52, "bt451.log": 4, "bu353-glonass.log": 8, "bu353s4.log": 2, "bundg_zeus_9.log": 2,
    "cat-ms352.log": 7, "ch-4701.log": 4, "ch-4711.log": 2, "ericsson-gru04-02-70sec.log": 5,
    "garmin-10x.log": 6, "garmin17n.log": 1, "gpsdf.log": 16, "gr601-w.log": 1, "iTrek.log": 3, "isync.log": 24,
    "jl-micro-jlt.log": 9, "mt3339.log": 7, "navika-100-fix.log": 2, "navisys-gr701w.log": 8,
    "navisys-gr8013.log": 10, "nl2008u.log": 5, "nl402u.log": 4, "nl551e.log": 1, "nmea-fuzzy-cases.log": 3,
    "nmea-rtk.log": 6, "nokia-ld-4w.log": 12, "pharos-360.log": 10, "quectel-eg25-g.log": 4,
    "quectel-l76k-dual.log": 5, "quectel.log": 4, "quectelLC79D-1.log": 4, "quectelLC79D.log": 18,
    "sirfstarv-nmea.log": 80, "skytraq-dgps.log": 154, "skytraq-fix.log": 16, "st-teseo-liv3f.log": 6,
    "st-teseo-liv4f.log": 4, "telit-he910.log": 16, "tomtom-mkII.log": 1, "ublox-8-time.log": 1,
    "ublox-8.log": 34, "ublox-aek-4t.log": 1, "ublox-lea-4h.log": 20, "ublox-lea-5h.log": 4,
    "ublox-neo-m8n.log": 5, "neo-m8n.log": 13, "ublox-neo-m8t.log": 7, "ublox-neo-m9n-nmea.log": 72, "ublox-zed-f9p-hp.log": 10,
    "ublox-zed-f9p-nmea.log": 67, "ublox-zed-f9r.log": 79, "ublox-zed-f9t-ubx_nmea_l5.log": 11,
    "ublox8-uniqid-monhw.log": 10, "venus634lp.log": 5,
}
for _name, _n in _DOP_COUNTS.items():
    GPSD_CHOICES.setdefault(_name, {})["dop"] = (_n, _DOP_RECOMPUTED)

_DOPS = ("gdop", "pdop", "hdop", "vdop", "tdop")


def gpsd_expected(chk: Path) -> tuple[dict, dict]:
    """gpsd's TPV mode per time label (the last TPV of each time) and its SKY DOPs per time (a SKY
    without a time belongs to the last TPV time before it)."""
    tpv: dict[str, int] = {}
    sky: dict[str, dict] = {}
    last = None
    for line in chk.read_text(errors="replace").splitlines():
        if line.startswith('{"class":"TPV"'):
            doc = json.loads(line)
            if "time" in doc:
                tpv[doc["time"]] = doc["mode"]
                last = doc["time"]
        elif line.startswith('{"class":"SKY"'):
            doc = json.loads(line)
            label = doc.get("time", last)
            if label is not None:
                sky[label] = doc
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
    dop_bad, dop_compared = 0, 0
    # NMEA sends no GDOP/TDOP: gpsd computes its own and so do we (geometry_dops, checked against the
    # receivers' own PDOP in test_receiver_readers); the receivers' DOPs are what is compared here
    names = ("pdop", "hdop", "vdop") if capture.protocols == ("nmea",) else _DOPS
    for t, doc in sky.items():
        if t not in index:
            continue
        for name in names:
            ours = float(rows[name][index[t]])
            if name in doc and np.isfinite(ours) and ours < 99.0:
                dop_compared += 1
                dop_bad += abs(doc[name] - ours) > 0.005
    return {"gpsd_epochs": len(tpv), "missing": len(missing), "mode": len(mode_bad), "dop": dop_bad,
            "dop_compared": dop_compared, "protocols": capture.protocols}


def test_the_oracle_covers_the_nmea_and_ubx_captures_with_a_reference_decoding():
    assert len(ORACLE_FILES) >= 150


@pytest.mark.parametrize("name", ORACLE_FILES)
def test_time_mode_and_dops_agree_with_gpsd_epoch_by_epoch(receivers, name):
    result = compare_with_gpsd(receivers / "gpsd" / name)
    if not result["protocols"]:
        pytest.skip(f"{name} holds no NMEA or UBX sentence we decode (another binary protocol, or a talker we do not use)")
    choices = GPSD_CHOICES.get(name, {})
    for key in ("missing", "mode", "dop"):
        expected = choices.get(key, (0, ""))[0]
        assert result[key] == expected, f"{name}: {key} {result[key]} != listed {expected} ({result})"


def test_every_listed_choice_names_a_capture_of_the_oracle():
    assert set(GPSD_CHOICES) <= set(ORACLE_FILES)


def test_week_rollover_dates_move_by_exactly_1024_weeks_with_a_reference(receivers):
    log = receivers / "gpsd" / "neo-m8n.log"
    as_sent = read_capture(log)
    tpv, _ = gpsd_expected(log.with_name(log.name + ".chk"))
    reference = int(datetime64_to_gps_ns(np.datetime64(next(iter(tpv)).rstrip("Z"), "ns")))
    moved = read_capture(log, reference_gps_ns=reference)
    shift = moved.utc_ns() - as_sent.utc_ns()
    assert np.all(shift == 1024 * 604_800 * NS_PER_S)
