"""RINEX 4 navigation files keep the ionosphere in ``> ION`` records: read, used, and checked against RTKLIB.

KMS3 (Septentrio PolaRx5, 2022-06-08, one hour at 30 s; tests/data/rinex/rinex4/README.md) has its GPS
Klobuchar coefficients only in an ``ION G29 LNAV`` record. Debian's rnx2rtkp (2.4.3 b34) does not read that
record and falls back on its built-in coefficients; given the same coefficients in a RINEX 3 header (the
file rewritten by the test), it must agree with ours epoch by epoch: that is the oracle of the values read.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from chronofuse.experiments.rtklib import run_rnx2rtkp
from chronofuse.gnss.point_positioning import SppOptions, point_positions, position_statistics
from chronofuse.io.rinex_nav import read_navigation
from chronofuse.io.rinex_obs import read_any_observations
from chronofuse.io.rinex_text import rinex_bytes
from chronofuse.validation import InputWarning


@pytest.fixture(scope="module")
def kms3(real_data):
    folder = real_data / "rinex" / "rinex4"
    obs_path = folder / "KMS300DNK_R_20221591000_01H_30S_MO.crx.gz"
    nav_path = folder / "KMS300DNK_R_20221591000_01H_MN.rnx.gz"
    obs = read_any_observations(obs_path, systems=("G",))
    return obs_path, nav_path, obs, read_navigation(nav_path)


def _rinex3_gps_nav(nav_path, alpha, beta, out) -> None:
    """The GPS LNAV records of a RINEX 4 file as a RINEX 3.04 GPS file, ``alpha``/``beta`` in its header."""
    lines = rinex_bytes(nav_path).decode("ascii").splitlines()
    body = lines.index(next(ln for ln in lines if "END OF HEADER" in ln)) + 1
    header = ["     3.04           N: GNSS NAV DATA    G: GPS".ljust(60) + "RINEX VERSION / TYPE"]
    for label, values in (("GPSA", alpha), ("GPSB", beta)):
        header.append((f"{label} " + "".join(f"{v:12.4E}" for v in values)).ljust(60) + "IONOSPHERIC CORR")
    header.append("    18".ljust(60) + "LEAP SECONDS")
    header.append("".ljust(60) + "END OF HEADER")
    records = []
    for i, line in enumerate(lines[body:], start=body):
        if line.startswith("> EPH G") and line.split()[-1] == "LNAV":
            records.extend(lines[i + 1:i + 9])
    out.write_text("\n".join(header + records) + "\n")


def test_the_gps_klobuchar_coefficients_of_a_rinex4_ion_record_are_read(kms3):
    _, _, _, nav = kms3
    assert nav.klobuchar_alpha is not None and nav.klobuchar_beta is not None
    # the broadcast scale factors (IS-GPS-200 Table 20-X): alpha_0 in units of 2^-30 s, beta_0 of 2^11 s
    counts = np.array([nav.klobuchar_alpha[0] * 2**30, nav.klobuchar_beta[0] / 2**11])
    assert np.all(np.abs(counts - np.round(counts)) < 1e-6) and np.all(np.round(counts) != 0)
    assert nav.bds_klobuchar_alpha is not None and nav.nequick_gal is not None
    assert nav.systems == ["G", "E", "C", "J"] and nav.n_skipped_records > 0  # GLONASS and SBAS skipped whole


def test_ours_from_the_ion_record_equals_rtklib_given_the_same_coefficients_in_a_header(kms3, tmp_path):
    obs_path, nav_path, obs, nav = kms3
    rewritten = tmp_path / "kms3_gps.rnx"
    _rinex3_gps_nav(nav_path, nav.klobuchar_alpha, nav.klobuchar_beta, rewritten)
    theirs = run_rnx2rtkp(obs_path, [rewritten], ("G",))
    ours = point_positions(obs, nav, ("G",))
    common, i, j = np.intersect1d(ours.gps_ns, theirs.gps_ns, return_indices=True)
    assert common.size == obs.gps_ns.size == 19
    apart = np.linalg.norm(ours.position_m[i] - theirs.position_m[j], axis=1)
    assert np.median(apart) < 0.1, apart
    # the negative control: without the ionosphere ours is metres away from that same solution
    bare = point_positions(obs, nav, ("G",), SppOptions(ionosphere="none"))
    assert np.median(np.linalg.norm(bare.position_m[i] - theirs.position_m[j], axis=1)) > 1.0


def test_kms3_horizontal95_is_within_1_1_times_rtklibs_on_the_rinex4_file(kms3):
    obs_path, nav_path, obs, nav = kms3
    reference = obs.header.approx_position_m  # the same point for both (no published coordinate shipped)
    theirs = run_rnx2rtkp(obs_path, [nav_path], ("G",))
    ours = point_positions(obs, nav, ("G",))
    h95_ours = position_statistics(ours.position_m, reference)["horizontal95_m"]
    h95_theirs = position_statistics(theirs.position_m, reference)["horizontal95_m"]
    assert h95_ours <= 1.1 * h95_theirs, (h95_ours, h95_theirs)
    bare = point_positions(obs, nav, ("G",), SppOptions(ionosphere="none"))
    assert position_statistics(bare.position_m, reference)["horizontal95_m"] > h95_ours


def test_a_navigation_file_without_gps_coefficients_warns_naming_it(igs_stations):
    s = igs_stations["AJAC"]  # Galileo-only navigation: NeQuick coefficients alone
    obs = s.observations().select(np.arange(10))
    nav = s.navigation()
    assert nav.klobuchar_alpha is None and nav.nequick_gal is not None
    with pytest.warns(InputWarning) as caught:
        point_positions(obs, nav, ("E",))
    message = str(caught[0].message)
    assert "GRAS00FRA" in message and "NeQuick" in message and "no ionospheric delay removed" in message
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        point_positions(obs, nav, ("E",), SppOptions(ionosphere="none"))  # nothing asked for, nothing to warn


def test_a_navigation_file_with_coefficients_gives_no_warning(kms3):
    _, _, obs, nav = kms3
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        point_positions(obs, nav, ("G",))
