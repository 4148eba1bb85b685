"""A broadcast record serves only within its system's validity around toe, as RTKLIB's ``seleph``: a stale
ephemeris must not give a fix. Oracle: rnx2rtkp on the same files (NYA1, tests/data/rinex/igs)."""

from __future__ import annotations

import numpy as np
import pytest

from chronofuse.experiments.rtklib import run_rnx2rtkp
from chronofuse.gnss.ephemeris import MAX_DTOE_S, select_ephemeris
from chronofuse.gnss.point_positioning import point_positions
from chronofuse.io.rinex_nav import read_navigation
from chronofuse.io.rinex_text import rinex_bytes
from chronofuse.timescale import NS_PER_S


def _records_from(nav_path, first_hour: int, out) -> None:
    """The RINEX 3 GPS file ``nav_path`` keeping only the records whose toc is at ``first_hour`` or later."""
    lines = rinex_bytes(nav_path).decode("ascii").splitlines()
    body = next(i for i, ln in enumerate(lines) if "END OF HEADER" in ln) + 1
    kept = lines[:body]
    for i in range(body, len(lines), 8):
        if int(lines[i][15:17]) >= first_hour:
            kept.extend(lines[i:i + 8])
    out.write_text("\n".join(kept) + "\n")


def test_the_validity_is_rtklibs_per_system():
    assert MAX_DTOE_S == {"G": 7200.0, "J": 7200.0, "E": 14400.0, "C": 21600.0}


def test_a_gps_record_more_than_two_hours_from_the_epoch_gives_no_satellite(igs_stations):
    s = igs_stations["NYA1"]
    nav = s.navigation()
    gps = [k for k, name in enumerate(nav.satellites) if name == "G05"]
    toe = int(nav.toe_gps_ns[gps].min())
    t = np.array([toe - 7300 * NS_PER_S, toe - 7100 * NS_PER_S], dtype=np.int64)
    eph = select_ephemeris(nav, ["G05"], t)
    assert eph.valid[:, 0].tolist() == [False, True]


@pytest.mark.parametrize("first_hour", [6])
def test_epochs_beyond_two_hours_before_the_first_gps_toe_get_no_fix_as_with_rtklib(igs_stations, tmp_path, first_hour):
    s = igs_stations["NYA1"]
    gps_nav = next(p for p in s.nav_paths if "_GN" in p.name)
    trimmed = tmp_path / "gn_from_06h.rnx"
    _records_from(gps_nav, first_hour, trimmed)
    nav = read_navigation(trimmed)
    first_toe = int(nav.toe_gps_ns.min())
    obs = s.observations()
    rows = obs.gps_ns < obs.gps_ns[0] + 8 * 3600 * NS_PER_S
    ours = point_positions(obs.select(rows), nav, ("G",))
    fixed = ours.gps_ns[np.isfinite(ours.position_m[:, 0])]
    theirs = run_rnx2rtkp(s.obs_path, [trimmed], ("G",))
    theirs_ns = theirs.gps_ns[theirs.gps_ns < obs.gps_ns[0] + 8 * 3600 * NS_PER_S]
    # the stale side: nothing earlier than 2 h before the first toe, from either
    assert fixed.min() >= first_toe - 7200 * NS_PER_S and theirs_ns.min() >= first_toe - 7200 * NS_PER_S
    # and the same epochs fixed, give or take a few where a satellite's window closes
    assert abs(int(fixed.min()) - int(theirs_ns.min())) <= 300 * NS_PER_S
    assert np.setxor1d(fixed, theirs_ns).size <= 0.02 * theirs_ns.size
