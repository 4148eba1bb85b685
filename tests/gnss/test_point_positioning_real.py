"""Single-point positioning on real IGS stations against their published coordinates and against RTKLIB."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from chronofuse.experiments.real_positioning import combinations_for, station_comparison
from chronofuse.experiments.rtklib import run_rnx2rtkp
from chronofuse.gnss.point_positioning import SppOptions, enu_errors_m, point_positions, position_statistics
from chronofuse.validation import InputDataError


def _first_hours(station, hours=3):
    obs = station.observations()
    return obs.select(obs.gps_ns < obs.gps_ns[0] + int(hours * 3600e9))


def test_the_four_stations_are_24_hours_of_four_systems_from_three_receiver_makes(igs_stations):
    makes = {s.make for s in igs_stations.values()}
    assert len(igs_stations) >= 4 and {"Trimble", "Septentrio", "Leica"} <= makes
    for s in igs_stations.values():
        obs = s.observations()
        assert obs.gps_ns.size == 2880 and obs.header.interval_s == 30.0 and obs.header.version >= 3.0
        assert (np.diff(obs.gps_ns) == 30_000_000_000).all()
        # the reference is a published coordinate, not the header's approximate position
        assert np.linalg.norm(s.reference_m - obs.header.approx_position_m) > 1e-3


@pytest.mark.parametrize("name,systems", [("NYA1", ("G",)), ("NYA1", ("G", "C")), ("ESBC", ("G", "E", "C")),
                                          ("BOR1", ("G",))])
def test_fixes_fall_within_a_few_metres_of_the_published_coordinate(igs_stations, name, systems):
    s = igs_stations[name]
    fixes = point_positions(_first_hours(s), s.navigation(), systems)
    stats = position_statistics(fixes.position_m, s.reference_arp_m)
    assert stats["availability"] > 0.99
    assert 0.2 < stats["horizontal95_m"] < 4.0 and stats["vertical95_m"] < 8.0
    # a wrong reference (10 m east) is seen: the statistics are not a constant
    off = s.reference_arp_m + np.cross([0.0, 0.0, 1.0], s.reference_arp_m) / np.linalg.norm(s.reference_arp_m[:2]) * 10
    assert position_statistics(fixes.position_m, off)["horizontal95_m"] > 8.0


def test_the_atmosphere_models_and_group_delays_each_reduce_the_error(igs_stations):
    s = igs_stations["NYA1"]
    obs, nav = _first_hours(s, 6), s.navigation()
    full = position_statistics(point_positions(obs, nav, ("G", "C")).position_m, s.reference_arp_m)
    bare = point_positions(obs, nav, ("G", "C"), SppOptions(ionosphere="none", troposphere="none"))
    bare = position_statistics(bare.position_m, s.reference_arp_m)
    p = dict(nav.params)
    p["group_delay_s"] = np.where([x[0] == "C" for x in nav.satellites], 0.0, p["group_delay_s"])
    no_tgd = point_positions(obs, dataclasses.replace(nav, params=p), ("C",))
    with_tgd = point_positions(obs, nav, ("C",))
    assert full["vertical95_m"] < 0.5 * bare["vertical95_m"]
    assert (position_statistics(with_tgd.position_m, s.reference_arp_m)["horizontal95_m"]
            < 0.6 * position_statistics(no_tgd.position_m, s.reference_arp_m)["horizontal95_m"])


def test_a_faulty_pseudorange_is_excluded_and_the_fix_does_not_move(igs_stations):
    s = igs_stations["ESBC"]
    obs = _first_hours(s, 1)
    clean = point_positions(obs, s.navigation(), ("G",))
    gps = np.flatnonzero(obs.system_mask("G"))
    sat = int(gps[np.argmax(np.isfinite(obs.values["C1C"][60:, gps]).sum(0))])  # one tracked all the hour
    values = dict(obs.values)
    bad = values["C1C"].copy()
    bad[60:, sat] += 60.0  # a 60 m step on one satellite after 30 min
    faulty = dataclasses.replace(obs, values={**values, "C1C": bad})
    screened = point_positions(faulty, s.navigation(), ("G",))
    unscreened = point_positions(faulty, s.navigation(), ("G",), SppOptions(max_exclusions=0))
    j = screened.satellites.index(obs.satellites[sat])
    seen = np.isfinite(bad[60:, sat])
    assert seen.sum() > 50 and (screened.n_excluded[60:][seen] >= 1).all()
    assert np.isnan(screened.residual_m[60:, j][seen]).all()
    # the oracle: the same epochs solved with that satellite removed by hand
    gone = values["C1C"].copy()
    gone[60:, sat] = np.nan
    removed = point_positions(dataclasses.replace(obs, values={**values, "C1C": gone}), s.navigation(), ("G",))
    shift = np.linalg.norm(screened.position_m - removed.position_m, axis=-1)[60:][seen]
    moved = np.linalg.norm(unscreened.position_m - clean.position_m, axis=-1)[60:][seen]
    assert np.median(shift) < 0.01 and np.median(moved) > 5.0
    assert (screened.n_excluded[:60] == clean.n_excluded[:60]).all()


def test_a_system_without_ephemeris_is_refused_naming_the_file(igs_stations):
    s = igs_stations["BOR1"]
    with pytest.raises(InputDataError, match="no BDS ephemeris") as err:
        point_positions(_first_hours(s, 0.1), s.navigation(), ("G", "C"))
    assert "BRDC00CNE" in str(err.value)


@pytest.mark.slow
def test_ours_and_rtklib_agree_on_every_real_station_and_gps_plus_bds_beats_gps_alone(igs_stations, rnx2rtkp):
    """Every station and combination its files support, RTKLIB's rnx2rtkp on the same files.

    Ours within 1.1x of RTKLIB's horizontal 95 % for GPS alone and GPS+BDS (and, for GPS alone, RTKLIB
    within 1.1x of ours: the two agree); epoch differences small where both use the same corrections."""
    report = {}
    for name, s in igs_stations.items():
        wanted = [c for c in ("gps", "gps+bds") if c in combinations_for(s)]
        if wanted:
            report[name] = station_comparison(s, wanted)
    gps_stations = [n for n, r in report.items() if "gps" in r["combinations"]]
    both = [n for n, r in report.items() if "gps+bds" in r["combinations"]]
    assert len(gps_stations) >= 3 and len(both) >= 2
    for name in gps_stations:
        row = report[name]["combinations"]["gps"]
        assert 1 / 1.1 < row["ratio_horizontal95"] < 1.1, (name, row)
        assert row["differences"]["horizontal_median_m"] < 0.3 and row["rtklib"]["availability"] > 0.98
    for name in both:
        c = report[name]["combinations"]
        assert c["gps+bds"]["ratio_horizontal95"] < 1.1, (name, c["gps+bds"])
        assert c["gps+bds"]["ours"]["horizontal95_m"] < c["gps"]["ours"]["horizontal95_m"]
        assert c["gps+bds"]["mean_satellites"] > c["gps"]["mean_satellites"] + 4
    print(json.dumps({n: {c: (round(v["ours"]["horizontal95_m"], 3), round(v["rtklib"]["horizontal95_m"], 3),
                              round(v["differences"]["horizontal_median_m"], 3))
                          for c, v in r["combinations"].items()} for n, r in report.items()}))


def test_rtklib_runs_on_the_files_and_its_fixes_match_ours_epoch_by_epoch(igs_stations, rnx2rtkp, tmp_path):
    s = igs_stations["BOR1"]
    obs = _first_hours(s, 1)
    ours = point_positions(obs, s.navigation(), ("G",))
    theirs = run_rnx2rtkp(s.obs_path, s.nav_paths, ("G",), program=rnx2rtkp)
    common, i, j = np.intersect1d(ours.gps_ns, theirs.gps_ns, return_indices=True)
    assert common.size == 120
    d = enu_errors_m(ours.position_m[i], s.reference_arp_m) - enu_errors_m(theirs.position_m[j], s.reference_arp_m)
    assert np.median(np.hypot(d[:, 0], d[:, 1])) < 0.1 and np.median(np.abs(d[:, 2])) < 0.2
