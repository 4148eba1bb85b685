"""Position-domain integrity (integrity/raim.py) for a receiver whose position is not known: the protection
levels bound the error at the stated probability whatever the size of a single-satellite fault, the false
alarms stay at the stated rate, a fault at its minimum detectable bias is missed no more often than stated,
exclusion names the faulty satellite, and each state is refused where it must not be given. Simulated
geometries (random sky, random site) carry the Monte Carlo claims, each with its exact binomial interval; a
brute-force second method (each subset solved on its own) checks the algebra; two real IGS stations check the
levels against their surveyed positions, with a fault injected on one satellite."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from _helpers import igs_station_catalogue

from chronofuse.analysis.metrics import clopper_pearson
from chronofuse.gnss.lsq_position import _enu_rotation, least_squares_position
from chronofuse.integrity.raim import STATES, RaimSettings, raim

_ORBIT_M = 26_560e3
_EARTH_M = 6_371e3
_CLOCK_M = 12_345.0
_OPEN = dict(horizontal_alert_limit_m=1e9, vertical_alert_limit_m=1e9)  # levels never over a limit


def sky(rng, epochs: int, n_sat: int, mask_deg: float = 10.0):
    """A random site and, per epoch, ``n_sat`` satellites on the GPS orbit sphere above the mask."""
    lat, lon = np.radians(rng.uniform(-70, 70)), np.radians(rng.uniform(-180, 180))
    up = np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])
    site = _EARTH_M * up
    d = rng.normal(size=(epochs * n_sat * 6, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    d = d[d @ up > np.sin(np.radians(mask_deg))][: epochs * n_sat].reshape(epochs, n_sat, 3)
    b = d @ site
    t = -b + np.sqrt(b * b - (site @ site - _ORBIT_M**2))
    return site, site + t[..., None] * d


def measure(rng, site, sat, sigma_m, bias_m=None, isb_m=None, system=None):
    rho = np.linalg.norm(sat - site, axis=-1) + _CLOCK_M + rng.normal(size=sat.shape[:2]) * sigma_m
    if isb_m is not None:
        rho = rho + np.where(system == 1, isb_m, 0.0)
    return rho if bias_m is None else rho + bias_m


def errors(site, result):
    enu = np.einsum("ij,ej->ei", _enu_rotation(site), result.position_m - site)
    return np.hypot(enu[:, 0], enu[:, 1]), np.abs(enu[:, 2])


def misleading(site, result):
    """Available epochs whose error is beyond a protection level: hazardously misleading information."""
    h, v = errors(site, result)
    available = np.isin(result.state, ("ok", "excluded"))
    return available & ((h > result.hpl_m) | (v > result.vpl_m))


def one_fault(rng, epochs, n_sat, sizes_m):
    bias = np.zeros((epochs, n_sat))
    faulty = rng.integers(0, n_sat, epochs)
    bias[np.arange(epochs), faulty] = sizes_m
    return bias, faulty


def test_fault_free_alarms_stay_within_the_stated_false_alarm_rate():
    rng = np.random.default_rng(11)
    epochs, n_sat, pfa = 3000, 9, 2e-2
    site, sat = sky(rng, epochs, n_sat)
    res = raim(sat, measure(rng, site, sat, 3.0), np.full((epochs, n_sat), 3.0), np.zeros(n_sat, int), site + 500.0,
               RaimSettings(pfa=pfa, **_OPEN))
    k = int(np.isin(res.state, ("alarm", "excluded")).sum())
    lo, _ = clopper_pearson(k, epochs, level=0.99)
    assert lo <= pfa, (k, epochs)
    assert not misleading(site, res).any()


@pytest.mark.parametrize("systems", [1, 2], ids=["gps", "gps+galileo"])
def test_the_integrity_risk_stays_under_its_budget_whatever_the_fault_size(systems):
    rng = np.random.default_rng(5 + systems)
    epochs, n_sat, budget = 4000, 9, 1e-2
    site, sat = sky(rng, epochs, n_sat)
    system = (np.arange(n_sat) % systems).astype(int)
    sigma = rng.uniform(1.0, 5.0, size=(epochs, n_sat))
    cfg = RaimSettings(pfa=1e-2, integrity_risk=budget, **_OPEN)
    clean = raim(sat, measure(rng, site, sat, sigma, isb_m=37.0, system=system), sigma, system, site + 300.0, cfg)
    # fault sizes spread over 0 .. 3x each satellite's minimum detectable bias: the sizes a detector finds
    # hardest (big enough to move the fix, small enough to slip under the thresholds)
    bias, faulty = one_fault(rng, epochs, n_sat, 0.0)
    mdb = clean.mdb_m[np.arange(epochs), faulty]
    bias[np.arange(epochs), faulty] = rng.uniform(0, 3, epochs) * np.where(np.isfinite(mdb), mdb, 100.0) \
        * rng.choice([-1, 1], epochs)
    res = raim(sat, measure(rng, site, sat, sigma, bias, isb_m=37.0, system=system), sigma, system, site + 300.0, cfg)
    k = int(misleading(site, res).sum())
    lo, hi = clopper_pearson(k, epochs, level=0.99)
    assert k / epochs <= budget and lo <= budget, (k, epochs, hi)
    assert (res.state == "unavailable").sum() == 0  # nine satellites: always enough to detect and exclude


def test_a_fault_at_its_minimum_detectable_bias_is_missed_no_more_often_than_stated():
    rng = np.random.default_rng(3)
    epochs, n_sat, p_md = 3000, 8, 5e-2
    site, sat = sky(rng, epochs, n_sat)
    sigma = np.full((epochs, n_sat), 2.0)
    cfg = RaimSettings(pfa=1e-3, p_md=p_md, **_OPEN)
    system = np.zeros(n_sat, int)
    clean = raim(sat, measure(rng, site, sat, sigma), sigma, system, site, cfg)
    bias, faulty = one_fault(rng, epochs, n_sat, 0.0)
    mdb = clean.mdb_m[np.arange(epochs), faulty]
    bias[np.arange(epochs), faulty] = mdb
    res = raim(sat, measure(rng, site, sat, sigma, bias), sigma, system, site, cfg)
    missed = int((res.state == "ok").sum())
    lo, _ = clopper_pearson(missed, epochs, level=0.99)
    assert lo <= p_md, (missed, epochs)
    # and a fault far below it mostly passes as "ok": the test is not alarming on everything
    small = raim(sat, measure(rng, site, sat, sigma, bias * 0.05), sigma, system, site, cfg)
    assert (small.state == "ok").mean() > 0.9


def test_exclusion_names_the_faulty_satellite_and_its_levels_bound_the_rest():
    rng = np.random.default_rng(8)
    epochs, n_sat = 1500, 10
    site, sat = sky(rng, epochs, n_sat)
    sigma = np.full((epochs, n_sat), 2.0)
    bias, faulty = one_fault(rng, epochs, n_sat, 150.0)
    res = raim(sat, measure(rng, site, sat, sigma, bias), sigma, np.zeros(n_sat, int), site + 1e3,
               RaimSettings(**_OPEN))
    assert (res.state == "ok").sum() == 0  # a 75-sigma fault never passes
    excluded = res.state == "excluded"
    assert excluded.mean() >= 0.95
    assert (res.excluded[excluded] == faulty[excluded]).mean() >= 0.95
    assert not misleading(site, res).any()
    assert np.all(res.n_used[excluded] == n_sat - 1)


@pytest.mark.parametrize("n_sat, size_m", [(6, 80.0), (6, 150.0), (7, 40.0), (8, 20.0)])
def test_with_few_satellites_a_fault_that_cannot_be_identified_is_an_alarm_and_no_satellite_is_named(n_sat, size_m):
    # With 6 satellites the rest of a wrong candidate, the fault still in it, can pass its own detection: the
    # strongest candidate that passed was the wrong one in 400 of 2000 epochs at 20 m and 128 at 150 m. Now
    # a satellite is named only when exactly one candidate's rest passes; otherwise the epoch is an alarm.
    rng = np.random.default_rng(100 + n_sat)
    epochs = 1500
    site, sat = sky(rng, epochs, n_sat)
    sigma = np.full((epochs, n_sat), 2.0)
    bias, faulty = one_fault(rng, epochs, n_sat, size_m)
    res = raim(sat, measure(rng, site, sat, sigma, bias), sigma, np.zeros(n_sat, int), site + 1e3,
               RaimSettings(**_OPEN))
    named = res.state == "excluded"
    wrong = int((res.excluded[named] != faulty[named]).sum())
    _, hi = clopper_pearson(wrong, int(named.sum()), level=0.99)
    assert named.sum() > 100 and hi < 0.01  # a named satellite is the faulty one, 99 % interval under 1 %
    assert not misleading(site, res).any()
    unnamed_alarms = (res.state == "alarm") & (res.excluded < 0)
    assert unnamed_alarms.any()  # the ambiguous epochs are given as alarms, not as ok nor as an exclusion


@pytest.mark.parametrize("size_m", [2e4, 5e4, 1e5, 3e5])
def test_a_fault_of_tens_to_hundreds_of_km_is_excluded_with_levels_that_still_bound(size_m):
    """A fault that pulls the all-in fix kilometres off: the rest is solved from its own iterated fix, not one
    linear step from the pulled one (which left errors of 100 m beyond levels of 15 m)."""
    rng = np.random.default_rng(int(size_m) % 97)
    epochs, n_sat = 300, 9
    site, sat = sky(rng, epochs, n_sat)
    bias, faulty = one_fault(rng, epochs, n_sat, size_m)
    res = raim(sat, measure(rng, site, sat, 1.0, bias), np.full((epochs, n_sat), 1.0), np.zeros(n_sat, int),
               site + 100.0, RaimSettings())
    assert not (res.state == "ok").any() and not misleading(site, res).any()
    named = res.excluded >= 0
    assert named.mean() > 0.9 and (res.excluded[named] == faulty[named]).all()


def test_unavailable_is_given_exactly_when_a_fault_could_not_be_detected_and_excluded():
    rng = np.random.default_rng(2)
    system = np.zeros(8, int)
    site, sat = sky(rng, 400, 8)
    sigma = np.full((400, 8), 3.0)
    rho = measure(rng, site, sat, sigma)
    # six satellites (4 unknowns + 2): available; five: never, with infinite levels
    six = raim(sat[:, :6], rho[:, :6], sigma[:, :6], system[:6], site, RaimSettings(**_OPEN))
    assert not (six.state == "unavailable").any()
    five = raim(sat[:, :5], rho[:, :5], sigma[:, :5], system[:5], site, RaimSettings(**_OPEN))
    assert (five.state == "unavailable").all() and np.isinf(five.hpl_m).all()
    # but a fault those five can detect (not exclude) is an alarm, never hidden as "unavailable"
    faulty = rho[:, :5].copy()
    faulty[:, 2] += 500.0
    five = raim(sat[:, :5], faulty, sigma[:, :5], system[:5], site, RaimSettings(**_OPEN))
    assert not (five.state == "ok").any() and (five.state == "alarm").mean() > 0.95
    # a second system's column untracked at these epochs adds no unknown: six GPS satellites stay available
    sat7 = np.concatenate([sat[:, :6], sat[:, 6:7]], 1)
    rho7 = np.concatenate([rho[:, :6], np.full((400, 1), np.nan)], 1)
    other = raim(sat7, rho7, sigma[:, :7], np.array([0, 0, 0, 0, 0, 0, 1]), site, RaimSettings(**_OPEN))
    assert not (other.state == "unavailable").any()
    # a satellite lost (NaN) leaves five: unavailable at those epochs only
    lost = rho[:, :6].copy()
    lost[::4, 2] = np.nan
    some = raim(sat[:, :6], lost, sigma[:, :6], system[:6], site, RaimSettings(**_OPEN))
    assert (some.state[::4] == "unavailable").all()
    assert not (np.delete(some.state, np.s_[::4]) == "unavailable").any()
    # levels over the alert limits: unavailable, never "ok"; the same epochs under generous limits are "ok"
    tight = raim(sat, rho, sigma, system, site, RaimSettings(horizontal_alert_limit_m=1.0, vertical_alert_limit_m=1.0))
    assert not (tight.state == "ok").any()
    loose = raim(sat, rho, sigma, system, site, RaimSettings(horizontal_alert_limit_m=500.0, vertical_alert_limit_m=500.0))
    assert (loose.state == "ok").mean() > 0.95


def test_the_levels_and_separations_agree_with_each_subset_solved_on_its_own():
    """Second method: every subset's position solved by its own iterated least squares and its covariance
    inverted from its own rows; the protection levels rebuilt from the module's formulas."""
    rng = np.random.default_rng(4)
    epochs, n_sat = 6, 8
    site, sat = sky(rng, epochs, n_sat)
    sigma = rng.uniform(1.0, 4.0, size=(epochs, n_sat))
    system = np.array([0, 0, 0, 0, 0, 1, 1, 1])
    rho = measure(rng, site, sat, sigma, isb_m=20.0, system=system)
    cfg = RaimSettings(pfa=1e-3, integrity_risk=1e-5, **_OPEN)
    res = raim(sat, rho, sigma, system, site + 200.0, cfg)
    k_axis = cfg.k_axis
    for e in range(epochs):
        rot = _enu_rotation(site)
        full = least_squares_position(sat[e], rho[e], sigma[e], system, site + 200.0, iterations=10)
        x0 = np.asarray(full.position_m)

        def cov(mask):
            d = sat[e][mask] - x0
            los = d / np.linalg.norm(d, axis=1, keepdims=True)
            g = np.column_stack([-(los @ rot.T), np.ones(mask.sum()), (system[mask] == 1).astype(float)])
            return np.linalg.inv(g.T @ np.diag(sigma[e][mask] ** -2) @ g)[:3, :3].diagonal()

        var0 = cov(np.ones(n_sat, bool))
        k_fa = math.sqrt(2) * float(__import__("scipy").special.erfcinv(cfg.pfa / (3 * n_sat)))
        pl = k_axis * np.sqrt(var0)
        top = 0.0
        for i in range(n_sat):
            keep = np.arange(n_sat) != i
            sub = least_squares_position(sat[e][keep], rho[e][keep], sigma[e][keep], system[keep], x0, iterations=10)
            delta = rot @ (np.asarray(sub.position_m) - x0)
            vari = cov(keep)
            sig_ss = np.sqrt(vari - var0)
            thresh = k_fa * sig_ss
            top = max(top, float(np.max(np.abs(delta) / thresh)))
            pl = np.maximum(pl, thresh + k_axis * np.sqrt(vari))
        assert res.max_statistic[e] == pytest.approx(top, rel=1e-4)
        assert res.hpl_m[e] == pytest.approx(math.hypot(pl[0], pl[1]), rel=1e-5)  # the ENU frame at the fix, not the site
        assert res.vpl_m[e] == pytest.approx(pl[2], rel=1e-5)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31), n_sat=st.integers(4, 12), sigma=st.floats(0.3, 8.0),
       pfa=st.floats(1e-5, 0.2), risk=st.floats(1e-7, 0.2), hal=st.floats(5.0, 200.0), fault=st.floats(-300, 300))
def test_every_epoch_state_follows_its_definition_over_drawn_scenarios(seed, n_sat, sigma, pfa, risk, hal, fault):
    rng = np.random.default_rng(seed)
    site, sat = sky(rng, 40, n_sat)
    bias, _ = one_fault(rng, 40, n_sat, fault)
    cfg = RaimSettings(pfa=pfa, integrity_risk=risk, horizontal_alert_limit_m=hal, vertical_alert_limit_m=1.5 * hal)
    res = raim(sat, measure(rng, site, sat, sigma, bias), np.full((40, n_sat), sigma), np.zeros(n_sat, int), site, cfg)
    assert set(res.state) <= set(STATES)
    if n_sat == 4:  # no redundancy: nothing can be detected
        assert (res.state == "unavailable").all()
        return
    if n_sat == 5:  # a fault can be detected, not excluded: an alarm, else unavailable
        assert set(res.state) <= {"alarm", "unavailable"}
        assert np.all(res.max_statistic[res.state == "alarm"] > 1.0)
        return
    available = np.isin(res.state, ("ok", "excluded"))
    assert np.all(res.hpl_m[available] <= hal) and np.all(res.vpl_m[available] <= 1.5 * hal)
    assert np.all(res.max_statistic[res.state == "ok"] <= 1.0)  # "ok": no separation over its threshold
    assert np.all(res.max_statistic[np.isin(res.state, ("excluded", "alarm"))] > 1.0)
    # an exclusion is named; after it the rest may have levels over a limit: then an alarm, still named
    assert np.all(res.excluded[res.state == "excluded"] >= 0)
    assert np.all(np.isin(res.state[res.excluded >= 0], ("excluded", "alarm")))  # alarm: the rest's levels over a limit
    # the no-fault floor of every level: K sigma of the all-in solution, so never below K * sigma / sqrt(n)
    assert np.all(res.hpl_m[available] > 0) and np.all(np.isfinite(res.hpl_m[available]))
    finite = res.mdb_m[np.isfinite(res.mdb_m)]
    assert np.all(finite > 0)


# -- real stations ---------------------------------------------------------------------------------------

STATIONS = igs_station_catalogue()


@pytest.fixture(scope="module")
def station_fixes():
    from chronofuse.gnss.point_positioning import SppOptions, point_positions

    out = {}
    for name in ("NYA1", "ESBC"):
        station = STATIONS[name]
        obs = station.observations().select(slice(0, None, 8))
        fix = point_positions(obs, station.navigation(), systems=("G", "E"),
                              options=SppOptions(elevation_mask_deg=10.0, max_exclusions=0))
        out[name] = (station, fix)
    return out


@pytest.mark.parametrize("name", ["NYA1", "ESBC"])
def test_on_a_real_station_the_levels_bound_the_error_against_its_surveyed_position(station_fixes, name):
    station, fix = station_fixes[name]
    site = station.reference_m
    res = raim(fix.satellite_m, fix.corrected_m, fix.sigma_m, fix.system_index, site + 100.0, RaimSettings())
    available = np.isin(res.state, ("ok", "excluded"))
    assert available.mean() > 0.95
    assert not misleading(site, res).any()
    h, _ = errors(site, res)
    assert np.median(h[available]) < 2.0  # a single-point fix, metres: far inside its HPL of 10-30 m
    assert np.median(res.hpl_m[available]) < 30.0


@pytest.mark.parametrize("name", ["NYA1", "ESBC"])
def test_on_a_real_station_a_fault_on_one_satellite_is_named_and_never_passes(station_fixes, name):
    station, fix = station_fixes[name]
    site = station.reference_m
    rho = np.array(fix.corrected_m, dtype=float)
    tracked = np.isfinite(rho)
    column = int(np.argmax(tracked.sum(0)))  # the satellite seen longest
    epochs = np.flatnonzero(tracked[:, column] & (tracked.sum(1) >= 8))
    rho[epochs, column] += 80.0
    res = raim(fix.satellite_m, rho, fix.sigma_m, fix.system_index, site + 100.0, RaimSettings())
    state = res.state[epochs]
    assert not (state == "ok").any()  # "no alarm" is never given with an 80 m fault beyond every MDB here
    assert (res.mdb_m[epochs, column] < 80.0).all()
    named = state == "excluded"
    assert named.mean() >= 0.9 and (res.excluded[epochs][named] == column).all()
    assert not misleading(site, res).any()


def test_detect_raim_on_a_real_station_from_the_command_line(tmp_path):
    import json
    import subprocess
    import sys

    station = STATIONS["ESBC"]
    args = [str(station.obs_path), *sum((["--nav", str(p)] for p in station.nav_paths), []), "--raim",
            "--position=" + ",".join(f"{v:.4f}" for v in station.reference_m), "--json", "--quiet"]
    code = "import sys; from chronofuse.cli.main import main; sys.argv = ['chronofuse', 'detect'] + sys.argv[1:]; main()"
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    assert doc["mode"] == "raim" and doc["state"] == "ok"
    assert doc["position_check"]["n_beyond_level"] == 0 and doc["availability"] > 0.95
    assert set(doc["epoch_states"]) == set(STATES)


@pytest.mark.parametrize("extra, words", [
    (["--raim"], "--nav"),
    (["--raim", "--nav", "NAV", "--integrity-risk", "0"], "--integrity-risk"),
    (["--raim", "--nav", "NAV", "--train", "60"], "--train"),
])
def test_detect_raim_refuses_what_it_cannot_do_in_one_line(tmp_path, extra, words):
    from typer.testing import CliRunner

    from chronofuse.cli.main import app

    station = STATIONS["ESBC"]
    extra = [str(station.nav_paths[0]) if a == "NAV" else a for a in extra]
    done = CliRunner().invoke(app, ["detect", str(station.obs_path), *extra])
    assert done.exit_code == 2, done.output
    assert words in done.output and len(done.output.strip().splitlines()) == 1, done.output


def test_detect_raim_on_a_clock_record_is_refused(tmp_path):
    from typer.testing import CliRunner

    from chronofuse.cli.main import app

    csv = tmp_path / "bias.csv"
    csv.write_text("t_s,clock_bias_s\n" + "".join(f"{k},{1e-9 * k}\n" for k in range(100)))
    done = CliRunner().invoke(app, ["detect", str(csv), "--raim", "--nav", str(csv)])
    assert done.exit_code == 2 and "RINEX observation" in done.output and str(csv) in done.output, done.output


def test_outside_the_single_fault_model_a_common_bias_is_invisible_and_two_faults_cost_what_the_docs_say():
    # The threat model is one faulty satellite per epoch. Two things beyond it, measured so the docs can say
    # what they cost. (1) A bias common to every satellite of the constellation (a constellation clock
    # fault, or a spoofer that shifts all ranges) is the receiver clock to the position solution: the states
    # and the position are exactly those of the clean epochs; it goes into the time, which RAIM does not
    # protect. (2) Two simultaneous faults, each up to 3x its satellite's minimum detectable bias: misleading
    # epochs 0.70 % (95 % CI 0.47..1.01 %) at 9 satellites and 0.27 % at 12 in 4000 epochs each
    # (docs/integrity/raim.md); asserted here on 2000 epochs at 9 satellites against the 1 % budget's CI.
    rng = np.random.default_rng(49)
    epochs, n_sat = 2000, 9
    site, sat = sky(rng, epochs, n_sat)
    sigma = np.full((epochs, n_sat), 3.0)
    cfg = RaimSettings(pfa=1e-2, integrity_risk=1e-2, **_OPEN)
    system = np.zeros(n_sat, int)
    rho = measure(rng, site, sat, sigma)
    clean = raim(sat, rho, sigma, system, site + 300.0, cfg)
    common = raim(sat, rho + 800.0, sigma, system, site + 300.0, cfg)
    assert np.array_equal(clean.state, common.state)
    assert np.allclose(clean.position_m, common.position_m, rtol=0, atol=1e-3)
    bias = np.zeros((epochs, n_sat))
    for e in range(epochs):
        two = rng.choice(n_sat, 2, replace=False)
        mdb = clean.mdb_m[e, two]
        bias[e, two] = rng.uniform(0, 3, 2) * np.where(np.isfinite(mdb), mdb, 100.0) * rng.choice([-1, 1], 2)
    res = raim(sat, rho + bias, sigma, system, site + 300.0, cfg)
    k = int(misleading(site, res).sum())
    lo, hi = clopper_pearson(k, epochs, level=0.95)
    assert 0 < k and lo <= 1e-2, (k, hi)  # some misleading epochs (outside the model), within the budget
    assert (res.state == "ok").mean() < 0.1  # most such epochs are caught: alarm or exclusion
