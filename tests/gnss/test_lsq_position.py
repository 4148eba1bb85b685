"""Batched weighted least-squares fixes: exact on exact ranges, chi-square consistent on noisy ones."""

from __future__ import annotations

import dataclasses

import math

import numpy as np
import pymap3d
import pytest
from scipy import stats

from chronofuse.gnss.constellation import constellation, satellite_positions_ecef
from chronofuse.gnss.lsq_position import least_squares_position
from chronofuse.gnss.simulate import ENVIRONMENTS, model_satellites, simulate_pseudoranges

RX = np.array(pymap3d.geodetic2ecef(30.5, 114.3, 30.0))


def _geometry(epochs: int = 20):
    t = np.linspace(0, 3600, epochs)
    sat = np.concatenate([satellite_positions_ecef(constellation("gps"), t),
                          satellite_positions_ecef(constellation("bds"), t)], axis=1)
    system = np.r_[np.zeros(24, int), np.ones(30, int)]
    d = sat - RX
    e, n, u = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], 30.5, 114.3)
    up = np.degrees(np.arctan2(u, np.hypot(e, n))) > 10
    return sat, system, up, np.linalg.norm(d, axis=-1)


def test_exact_ranges_give_the_position_clock_and_inter_system_bias_exactly():
    sat, system, up, r = _geometry()
    rho = np.where(up, r + 300.0 + np.where(system == 1, -42.0, 0.0), np.nan)
    fix = least_squares_position(sat, rho, np.ones_like(rho), system, RX + 50e3)
    assert np.abs(fix.position_m - RX).max() < 1e-4
    assert np.allclose(fix.clock_m, 300.0, atol=1e-4) and np.allclose(fix.isb_m[:, 0], -42.0, atol=1e-4)


def test_the_dops_obey_their_identities_and_match_a_per_epoch_lstsq():
    sat, system, up, r = _geometry(5)
    rho = np.where(up, r, np.nan)
    fix = least_squares_position(sat[:, :24], rho[:, :24], np.ones((5, 24)), system[:24], RX)
    assert np.allclose(fix.gdop**2, fix.pdop**2 + fix.tdop**2)
    assert np.allclose(fix.pdop**2, fix.hdop**2 + fix.vdop**2)
    k = 2
    ok = up[k, :24]
    los = (sat[k, :24][ok] - RX) / r[k, :24][ok, None]
    g = np.column_stack([-los, np.ones(ok.sum())])
    q = np.linalg.inv(g.T @ g)
    assert fix.gdop[k] == pytest.approx(math.sqrt(np.trace(q)), rel=1e-9)


def test_the_reported_covariance_is_chi_square_consistent_with_the_errors():
    sat, system, up, r = _geometry(50)
    rng = np.random.default_rng(1)
    sigma = np.full((200, 50, 54), 2.0)
    rho = np.where(up, r, np.nan) + sigma * rng.standard_normal(sigma.shape)
    fix = least_squares_position(sat, rho, sigma, system, RX)
    lat, lon = math.radians(30.5), math.radians(114.3)
    d = fix.position_m - RX
    e, n, u = pymap3d.uvw2enu(d[..., 0], d[..., 1], d[..., 2], lat, lon, deg=False)
    err = np.stack([e, n, u], -1)
    d2 = np.einsum("...i,...i->...", err, np.linalg.solve(fix.cov_enu_m2, err[..., None])[..., 0])
    # Mean of chi2(3) over 10,000 fixes: 3 within its standard error sqrt(6 / 1e4).
    assert abs(d2.mean() - 3.0) < 4 * math.sqrt(6.0 / d2.size)
    assert stats.kstest(d2.ravel(), "chi2", args=(3,)).pvalue > 1e-3


def test_too_few_satellites_give_nan_not_a_wrong_fix():
    sat, system, up, r = _geometry(3)
    rho = np.full((3, 54), np.nan)
    rho[:, :3] = r[:, :3]  # three GPS only: one fewer than position and clock need
    fix = least_squares_position(sat, rho, np.ones_like(rho), system, RX)
    assert np.isnan(fix.position_m).all() and (fix.n_used == 3).all()


def test_a_system_without_satellites_leaves_its_bias_held_and_the_fix_exact():
    sat, system, up, r = _geometry(3)
    gps = np.flatnonzero(system == 0)[:4]
    rho = np.full((3, 54), np.nan)
    rho[:, gps] = r[:, gps]  # four GPS, no BDS: the inter-system bias is held at zero, not needed
    fix = least_squares_position(sat, rho, np.ones_like(rho), system, RX)
    good = np.isfinite(fix.position_m).all(-1)
    assert good.any() and (fix.n_used == 4).all()
    assert np.abs(fix.position_m[good] - RX).max() < 1e-3 and np.abs(fix.isb_m[good]).max() < 1e-6


def test_a_canyon_hides_satellites_across_the_street_and_a_tunnel_hides_all():
    receiver = np.broadcast_to(RX, (2, 400, 3))
    heading = np.zeros((2, 400))
    t = np.arange(400.0)
    sats = model_satellites(("gps", "bds"), t)
    open_sky = simulate_pseudoranges(receiver, heading, t, sats, ENVIRONMENTS["open-sky"], seed=3)
    direct_only = dataclasses.replace(ENVIRONMENTS["urban-canyon"], nlos_probability=0.0)
    canyon = simulate_pseudoranges(receiver, heading, t, sats, direct_only, seed=3)
    tunnel = simulate_pseudoranges(receiver, heading, t, sats, ENVIRONMENTS["tunnel"], seed=3)
    seen = lambda obs: np.isfinite(obs.pseudorange_m).sum(-1)  # noqa: E731
    assert (seen(canyon) < seen(open_sky)).all()
    assert (seen(tunnel)[:, 300:360] == 0).all() and (seen(tunnel)[:, :300] == seen(open_sky)[:, :300]).all()


def test_blocked_satellites_come_back_by_reflection_with_a_longer_path_only_in_the_canyon():
    receiver = np.broadcast_to(RX, (4, 600, 3))
    heading = np.zeros((4, 600))
    t = np.arange(600.0)
    sats = model_satellites(("gps",), t)
    env = ENVIRONMENTS["urban-canyon"]
    quiet = dataclasses.replace(env, nlos_probability=0.0)
    with_nlos = simulate_pseudoranges(receiver, heading, t, sats, env, seed=4)
    direct = simulate_pseudoranges(receiver, heading, t, sats, quiet, seed=4)
    extra = np.isfinite(with_nlos.pseudorange_m) & ~np.isfinite(direct.pseudorange_m)
    fraction = extra.sum() / (np.isfinite(with_nlos.pseudorange_m).sum())
    assert 0.05 < fraction < 0.6  # a share of the blocked satellites, received by reflection
    # same draws for the direct signals, so the reflected ones are recognisable by their excess path:
    # geometric range plus errors of a few metres plus 2 (W / 2) cos(el) |sin(az - heading)| > 0
    excess = with_nlos.pseudorange_m - np.linalg.norm(sats.position_m[None] - RX, axis=-1) - with_nlos.clock_m[..., None]
    assert np.nanmedian(excess[extra]) > np.nanmedian(excess[np.isfinite(direct.pseudorange_m)]) + 5.0


def test_simulated_open_sky_fixes_scatter_as_sigma_times_pdop_says():
    receiver = np.broadcast_to(RX, (20, 300, 3))
    env = ENVIRONMENTS["open-sky"]
    t = np.arange(300.0)
    obs = simulate_pseudoranges(receiver, np.zeros((20, 300)), t, model_satellites(("gps", "bds"), t), env, seed=5)
    fix = least_squares_position(obs.satellite_m, obs.pseudorange_m, obs.sigma_m, obs.system, RX + 1e4)
    err = np.linalg.norm(fix.position_m - RX, axis=-1)
    assert np.isfinite(err).all()
    assert np.abs(fix.isb_m[..., 0] - obs.isb_m[:, None, 0]).mean() < 3.0
    # The reported sigma holds code noise and multipath only; the residual ionosphere and troposphere
    # (time-correlated, not in sigma) add to it, so the 3-D rms sits above the predicted scale
    # sqrt(trace cov), by the atmosphere's share, and well under 10 m.
    predicted = np.sqrt(np.trace(fix.cov_enu_m2, axis1=-2, axis2=-1))
    assert 1.0 < np.sqrt(np.mean(err**2)) / np.sqrt(np.mean(predicted**2)) < 6.0 and np.sqrt(np.mean(err**2)) < 10
    assert np.sqrt(np.mean(err**2)) < 10.0
