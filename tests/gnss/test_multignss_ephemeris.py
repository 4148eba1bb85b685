"""Broadcast ephemerides of GPS, Galileo and BeiDou from RINEX 3 navigation files, checked against a precise
orbit product (GRG MGX final, SP3), georinex's decoding, and the systems' time-scale definitions."""

from __future__ import annotations

import gzip
import logging
import warnings

import numpy as np
import pytest

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S
from chronofuse.gnss.ephemeris import satellite_clock_s, satellite_position_ecef, select_ephemeris
from chronofuse.io.rinex_nav import merge_navigation, read_navigation
from chronofuse.timescale import NS_PER_S, datetime64_to_gps_ns, gps_ns_from_week_tow, seconds_to_ns
from chronofuse.validation import InputDataError


def _sp3(path):
    """Positions (km -> m) and clocks (us -> s) of an SP3-c/d file: {sat: (gps_ns, xyz_m, clock_s)}."""
    out: dict[str, list] = {}
    t = None
    with gzip.open(path, "rt") as f:
        for line in f:
            if line.startswith("*  "):
                y, mo, d, h, mi = (int(v) for v in line[3:20].split())
                sec = float(line[20:31])
                stamp = np.datetime64(f"{y:04d}-{mo:02d}-{d:02d}T{h:02d}:{mi:02d}:00", "ns")
                t = int(datetime64_to_gps_ns(np.array([stamp]))[0]) + int(round(sec * NS_PER_S))
            elif line.startswith("P") and t is not None:
                x, yy, z, clk = (float(line[4 + 14 * k:18 + 14 * k]) for k in range(4))
                out.setdefault(line[1:4], []).append((t, x * 1e3, yy * 1e3, z * 1e3, clk * 1e-6))
    return {k: (np.array([r[0] for r in v]), np.array([r[1:4] for r in v]), np.array([r[4] for r in v]))
            for k, v in out.items()}


@pytest.fixture(scope="module")
def esbc_day(igs_stations):
    station = igs_stations["ESBC"]
    sp3 = _sp3(station.obs_path.parent / "GRG0MGXFIN_20201770000_01D_15M_ORB.SP3.gz")
    return station.navigation(), sp3


@pytest.mark.parametrize("letter", ["G", "E"])
def test_broadcast_orbits_agree_with_the_precise_orbits_to_the_broadcast_accuracy(esbc_day, letter):
    nav, sp3 = esbc_day
    errors = []
    for sat, (t, xyz, _) in sp3.items():
        if sat[0] != letter or sat not in nav.satellites:
            continue
        eph = select_ephemeris(nav, [sat], t, max_age_s=7200.0)
        # where the station had received a record valid at the epoch (Galileo's from its toe on; the precise
        # orbit also covers hours before the satellite rose over the station and its first record arrived)
        ok = eph.valid[:, 0] & ((t - eph.toe_gps_ns[:, 0]) >= (-900 if letter == "E" else -7200) * NS_PER_S)
        if ok.sum() < 20:
            continue
        ours = satellite_position_ecef(eph, t)[ok, 0]
        errors.append(np.linalg.norm(ours - xyz[ok], axis=-1))
    err = np.concatenate(errors)
    assert len(errors) >= 20
    # Signal-in-space orbit errors are about 1-2 m (GPS) and under 1 m (Galileo) RMS, plus the antenna
    # phase-centre offset of the broadcast orbit against the precise centre of mass (up to ~1.5 m): a wrong
    # constant, week or rotation gives kilometres.
    assert np.median(err) < 2.5 and np.percentile(err, 99) < 6.0


@pytest.mark.parametrize("letter", ["G", "E"])
def test_broadcast_clocks_track_the_precise_clocks_up_to_one_offset_per_epoch(esbc_day, letter):
    nav, sp3 = esbc_day
    sats = [s for s in sp3 if s[0] == letter and s in nav.satellites]
    t = sp3[sats[0]][0]
    rows = []
    for sat in sats:
        ts, _, clk = sp3[sat]
        if ts.size != t.size or not (ts == t).all():
            continue
        eph = select_ephemeris(nav, [sat], t, max_age_s=7200.0)
        # SP3 clocks are the ionosphere-free clock without the periodic relativistic term the user adds
        # (IGS SP3-d conventions): compare the broadcast polynomial, then check the relativistic term apart
        p = eph.params
        dt = (t - eph.toc_gps_ns[:, 0]) / NS_PER_S
        ours = p["af0_s"][:, 0] + p["af1_s_per_s"][:, 0] * dt + p["af2_s_per_s2"][:, 0] * dt**2
        relativity = satellite_clock_s(eph, t, l1_tgd=False)[:, 0] - ours
        assert not eph.valid.any() or np.nanmax(np.abs(relativity)) < 60e-9  # F e sqrt(A) sin E: tens of ns
        rows.append(np.where(eph.valid[:, 0] & (np.abs(clk) < 0.9), ours - clk, np.nan))
    diff = np.array(rows) * SPEED_OF_LIGHT_M_PER_S
    diff = diff - np.nanmedian(diff, axis=0)  # the product's time scale differs from GPS time by one offset
    assert diff.shape[0] >= 20 and np.nanpercentile(np.abs(diff), 95) < 3.0


def test_beidou_epochs_are_bdt_and_weeks_count_from_2006(igs_stations):
    nav = read_navigation(igs_stations["NYA1"].nav_paths[2])
    assert nav.systems == ["C"]
    week = nav.params["week"].astype(np.int64)
    expected = gps_ns_from_week_tow(week + 1356, seconds_to_ns(nav.params["toe_s"])) + 14 * NS_PER_S
    assert (nav.toe_gps_ns == expected).all()
    # BDT = GPST - 14 s: a record's toc written 00:00:00 BDT is 00:00:14 GPS time
    assert ((nav.toc_gps_ns - 14 * NS_PER_S) % (3600 * NS_PER_S) == 0).all()


def test_our_gps_records_equal_georinex_decoding(igs_stations):
    import georinex

    path = igs_stations["NYA1"].nav_paths[0]
    ours = read_navigation(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        logging.disable(logging.CRITICAL)
        try:
            theirs = georinex.load(path)
        finally:
            logging.disable(logging.NOTSET)
    names = {"sqrt_a_sqrt_m": "sqrtA", "eccentricity": "Eccentricity", "m0_rad": "M0", "toe_s": "Toe",
             "af0_s": "SVclockBias", "tgd_s": "TGD", "omega_dot_rad_per_s": "OmegaDot", "accuracy_m": "SVacc"}
    toc = datetime64_to_gps_ns(theirs.time.values)
    checked = 0
    for k, sat in enumerate(ours.satellites):
        i = int(np.flatnonzero(toc == ours.toc_gps_ns[k])[0])
        for mine, name in names.items():
            assert ours.params[mine][k] == pytest.approx(float(theirs[name].sel(sv=sat).values[i]), rel=1e-12, abs=1e-30)
            checked += 1
    assert checked == len(names) * len(ours.satellites) > 1000


def test_a_mixed_file_holds_three_systems_and_the_station_files_merge(igs_stations):
    mixed = igs_stations["ESBC"].navigation()
    assert mixed.systems == ["G", "E", "C", "J"] and mixed.n_skipped_records > 0  # GLONASS, SBAS skipped
    merged = igs_stations["NYA1"].navigation()
    assert merged.systems == ["G", "E", "C"] and merged.klobuchar_alpha is not None


def test_a_beidou_geo_stays_over_its_longitude_at_geostationary_height(igs_stations):
    nav = igs_stations["ESBC"].navigation()
    geos = sorted({s for s, g in zip(nav.satellites, nav.params["geo"]) if g == 1.0})
    assert geos, "the ESBC file has BeiDou GEO records"
    t = nav.toc_gps_ns.min() + np.arange(0, 86_400, 900, dtype=np.int64) * NS_PER_S
    eph = select_ephemeris(nav, geos, t)
    xyz = satellite_position_ecef(eph, t)
    radius = np.linalg.norm(xyz, axis=-1)[eph.valid]
    lon = np.degrees(np.arctan2(xyz[..., 1], xyz[..., 0]))
    assert np.abs(radius - 42_164e3).max() < 60e3  # geostationary radius, within the orbits' eccentricity
    spread = np.nanmax(np.where(eph.valid, lon, np.nan), 0) - np.nanmin(np.where(eph.valid, lon, np.nan), 0)
    assert np.nanmax(spread) < 3.0  # over a day a GEO wanders well under a few degrees of longitude


def test_a_damaged_navigation_record_is_refused_naming_the_line(tmp_path, igs_stations):
    lines = gzip.open(igs_stations["NYA1"].nav_paths[0], "rt").read().splitlines(keepends=True)
    body = next(i for i, line in enumerate(lines) if "END OF HEADER" in line) + 1
    lines[body + 2] = lines[body + 2][:4] + "  not a number     " + lines[body + 2][23:]
    bad = tmp_path / "bad.rnx"
    bad.write_text("".join(lines))
    with pytest.raises(InputDataError, match=f"line {body + 1}"):
        read_navigation(bad)
    short = tmp_path / "short.rnx"
    short.write_text("".join(lines[:body + 3]))
    with pytest.raises(InputDataError, match="cut short"):
        read_navigation(short)
    assert merge_navigation([read_navigation(igs_stations["NYA1"].nav_paths[0])]).systems == ["G"]
