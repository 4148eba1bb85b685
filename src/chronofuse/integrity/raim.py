"""Position-domain integrity for a receiver whose position is not known (RAIM in the ARAIM spirit): protection
levels against alert limits, fault detection and exclusion by solution separation, the minimum detectable
bias, missed-detection probability and time to alert, one epoch at a time (snapshot).

Threat model: at most one satellite faulty at an epoch (a bias of any size on its pseudorange), the others'
errors zero-mean Gaussian with the 1-sigma the caller gives (``sigma_m``). Per epoch (Blanch et al. 2012,
"Baseline advanced RAIM user algorithm", simplified: no nominal biases, no prior fault probability):

1. **All-in solution.** Weighted least squares (:func:`chronofuse.gnss.lsq_position.least_squares_position`)
   on every usable satellite; the model is linearised at the fix: design ``G`` (east, north, up, clock, one
   inter-system bias per system after the first), weights ``W = diag(1/sigma^2)``, residuals ``y``;
   ``S_0 = (G^T W G)^-1 G^T W`` and ``sigma_0,q^2 = ((G^T W G)^-1)_qq`` for ``q`` in east, north, up.
2. **Subsets.** For each satellite ``i`` the solution without it: ``S_i`` with ``w_i = 0`` (a system left
   with no satellite has its bias held at zero); the separation ``Delta_i = (S_i - S_0) y`` (position of
   subset ``i`` minus the all-in one), whose fault-free variance is ``sigma_ss,i,q^2 = sigma_i,q^2 -
   sigma_0,q^2`` (``x_0`` is the efficient estimate, so ``cov(x_i - x_0) = P_i - P_0``).
3. **Detection.** Alarm when any ``|Delta_i,q| > T_i,q = K_fa sigma_ss,i,q``, ``K_fa = Phi^-1(1 - pfa / (2 *
   3 N))`` over the ``3 N`` tests of the epoch (Bonferroni: ``P(false alarm) <= pfa`` whatever their
   correlation).
4. **Protection levels.** Per axis ``PL_q = max(K_q sigma_0,q, max_i (T_i,q + K_q sigma_i,q))`` with
   ``K_q = Phi^-1(1 - P_q / 2)``; the integrity risk ``integrity_risk`` is split half horizontal (a quarter
   each to east and north) and half vertical. ``HPL = sqrt(PL_E^2 + PL_N^2)`` (if both axes are inside their
   levels the horizontal error is inside ``HPL``), ``VPL = PL_U``. Why it bounds, for any fault size: with no
   fault, ``P(|e_0,q| > PL_q) <= P(|e_0,q| > K_q sigma_0,q) = P_q``; with satellite ``i`` faulty and no
   alarm, ``|Delta_i,q| <= T_i,q`` and ``e_0 = e_i - Delta_i`` where ``e_i`` (subset ``i``, fault-free) is
   Gaussian with ``sigma_i``: ``P(|e_0,q| > PL_q, no alarm) <= P(|e_i,q| > K_q sigma_i,q) = P_q``. So
   ``P(error beyond a level and no alarm) <= integrity_risk`` under every hypothesis of the threat model.
5. **Exclusion.** At an alarm, the :data:`MAX_EXCLUSION_CANDIDATES` candidates ``j`` with the largest
   normalised separation ``max_q |Delta_j,q| / sigma_ss,j,q`` are each left out and steps 1-4 run again on
   the rest; if exactly one rest passes its own detection, that candidate is excluded and its protection
   levels are the epoch's (valid by the same argument on the rest: the fault was ``j`` and the rest is
   fault-free, or it is still in the rest and the rest's detection covers it). None passing, or more than
   one (the fault detected but not identified: with few satellites a rest that still holds the fault can
   pass, and the strongest candidate was then the wrong one in 6 % of 150 m faults with 6 satellites):
   ``alarm``, no satellite named.
6. **Minimum detectable bias** of satellite ``i``: a bias ``b`` on it moves ``Delta_i`` by ``-S_0[:, i] b``
   (subset ``i`` does not see it), so test ``(i, q)`` alarms with probability at least ``1 - p_md`` when
   ``|b| >= MDB_i = min_q (T_i,q + K_md sigma_ss,i,q) / |S_0[q, i]|``, ``K_md = Phi^-1(1 - p_md)``.

Epoch states: ``ok`` (no alarm, levels inside the alert limits), ``excluded`` (a satellite detected and
excluded, levels inside), ``alarm`` (detected, and no exclusion passes, or the rest after the exclusion has a
level over its alert limit: ``excluded`` still names the satellite left out; with ``unknowns + 1`` satellites
a fault can be detected but not excluded: an alarm too, never hidden), ``unavailable`` (no alarm, and fewer
than ``unknowns + 2`` satellites, or a level over its alert limit; ``unknowns`` counts the systems the epoch
has satellites of). An excluded candidate's solution is its own fix, iterated from the all-in one: a fault of
tens of kilometres pulls the all-in fix so far that one linear step from it does not reach the rest's. Time to alert: the decision is made from the epoch's own measurements, so an alarm comes at the
epoch whose data carry the fault (the time to alert is the processing latency, under one epoch interval).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from chronofuse.gnss.lsq_position import _enu_rotation, least_squares_position
from chronofuse.validation import check_scalar

__all__ = ["RaimSettings", "RaimResult", "raim", "MAX_EXCLUSION_CANDIDATES", "STATES"]

#: Candidates tried, strongest first, before an alarm is declared not excludable.
MAX_EXCLUSION_CANDIDATES = 3

#: The epoch states, in this order of precedence where one epoch could be read two ways.
STATES = ("ok", "excluded", "alarm", "unavailable")


@dataclass(frozen=True)
class RaimSettings:
    """``pfa``: false-alarm probability per epoch (all separation tests together); ``integrity_risk``: the
    per-epoch budget of ``P(position error beyond a protection level and no alarm)``; ``p_md``: the
    missed-detection probability at which the minimum detectable bias is stated; alert limits (m)."""

    pfa: float = 1e-3
    integrity_risk: float = 1e-4
    p_md: float = 1e-3
    horizontal_alert_limit_m: float = 40.0
    vertical_alert_limit_m: float = 50.0

    def __post_init__(self):
        for name in ("pfa", "integrity_risk", "p_md"):
            check_scalar(getattr(self, name), name, min_val=0.0, max_val=0.5, include_min=False)
        for name in ("horizontal_alert_limit_m", "vertical_alert_limit_m"):
            check_scalar(getattr(self, name), name, min_val=0.0, include_min=False)

    @property
    def k_axis(self) -> np.ndarray:
        """``K_q`` for east, north, up (module docstring, step 4)."""
        p = np.array([self.integrity_risk / 4, self.integrity_risk / 4, self.integrity_risk / 2])
        return stats.norm.isf(p / 2)


@dataclass(frozen=True)
class RaimResult:
    """Per epoch: ``state`` (object array of :data:`STATES`), ``position_m`` (E, 3) ECEF of the solution the
    state refers to (all-in, or without the excluded satellite), ``hpl_m``, ``vpl_m``, ``excluded`` (E,) the
    column left out (-1: none), ``n_used``, ``mdb_m`` (E, S) each satellite's minimum detectable bias (inf:
    undetectable, NaN: not used), ``max_statistic`` (E,) the largest ``|Delta_i,q| / T_i,q`` of the all-in
    set (over 1: alarm)."""

    state: np.ndarray
    position_m: np.ndarray
    hpl_m: np.ndarray
    vpl_m: np.ndarray
    excluded: np.ndarray
    n_used: np.ndarray
    mdb_m: np.ndarray
    max_statistic: np.ndarray


def _design(satellite_m, position_m, system, n_systems):
    """ENU design rows (E, S, 3 + n_systems) and predicted ranges (E, S) at the fixes ``position_m`` (E, 3)."""
    d = satellite_m - position_m[:, None, :]
    r = np.linalg.norm(d, axis=-1)
    rot = _enu_rotation(position_m)  # (E, 3, 3) rows e, n, u
    los_enu = np.einsum("eij,esj->esi", rot, d / r[..., None])
    onehot = (system[..., None] == np.arange(1, n_systems)).astype(np.float64)  # (E, S, n_systems - 1)
    g = np.concatenate([-los_enu, np.ones(r.shape + (1,)), onehot], -1)
    return g, r


def _separations(g, w, y, system, n_systems, k_axis, pfa):
    """Steps 1-4 and 6 on weights ``w`` (E, S) (0: not used): a dict of per-epoch arrays."""
    e, s, u = g.shape
    used = w > 0
    n_used = used.sum(-1)

    def normal_inv(weights):
        sysb = system if weights.ndim == 2 else system[:, None, :]
        present = np.stack([((weights > 0) & (sysb == j)).any(-1) for j in range(n_systems)], -1)
        hold = np.zeros(weights.shape[:-1] + (u, u))
        idx = np.arange(3, u)
        hold[..., idx, idx] = np.where(present, 0.0, 1.0)
        gg = g if weights.ndim == 2 else g[:, None]  # (E, S, U) or (E, 1, S, U) against subsets
        gw = gg * weights[..., None]
        normal = np.swapaxes(gw, -1, -2) @ gg + hold
        # fewer satellites than unknowns (an epoch of 3, a subset of an epoch of 4): no solution; the
        # identity keeps the batch invertible and those epochs are unavailable (not enough satellites)
        short = (weights > 0).sum(-1) < 3 + present.sum(-1)
        normal[short] = np.eye(u)
        try:
            return np.linalg.inv(normal), gw
        except np.linalg.LinAlgError:  # a degenerate geometry among them (satellites in one plane)
            return np.linalg.pinv(normal), gw

    p0, gw0 = normal_inv(w)
    s0 = p0 @ np.swapaxes(gw0, -1, -2)  # (E, U, S)
    x0 = np.einsum("eus,es->eu", s0, np.where(used, y, 0.0))
    wi = np.broadcast_to(w[:, None, :], (e, s, s)).copy()
    wi[:, np.arange(s), np.arange(s)] = 0.0
    pi, gwi = normal_inv(wi)  # (E, S, U, U)
    si = pi @ np.swapaxes(gwi, -1, -2)  # (E, S, U, S)
    xi = np.einsum("eius,es->eiu", si, np.where(used, y, 0.0))
    delta = (xi - x0[:, None, :])[..., :3]  # (E, S, 3)
    var0 = np.diagonal(p0, axis1=-2, axis2=-1)[..., :3]  # (E, 3)
    vari = np.diagonal(pi, axis1=-2, axis2=-1)[..., :3]  # (E, S, 3)
    sig_ss = np.sqrt(np.maximum(vari - var0[:, None, :], 0.0))
    n_tests = np.maximum(3 * n_used, 1)
    k_fa = stats.norm.isf(pfa / (2.0 * n_tests))  # (E,)
    thresh = k_fa[:, None, None] * sig_ss
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(used[..., None] & (sig_ss > 1e-9), np.abs(delta) / thresh, 0.0)
    alarm = (ratio > 1.0).any(axis=(1, 2))
    sig0, sigi = np.sqrt(var0), np.sqrt(vari)
    pl_sub = np.where(used[..., None], thresh + k_axis * sigi, 0.0).max(axis=1)  # (E, 3)
    pl = np.maximum(k_axis * sig0, pl_sub)
    sens = np.abs(np.swapaxes(s0[:, :3, :], 1, 2))  # (E, S, 3): |S_0[q, i]|
    return {"used": used, "n_used": n_used, "x0": x0, "alarm": alarm, "ratio": ratio, "thresh": thresh,
            "sig_ss": sig_ss, "sens": sens, "hpl": np.hypot(pl[:, 0], pl[:, 1]), "vpl": pl[:, 2],
            "k_fa": k_fa}


def _linearised(sat, rho, sig, system, n_systems, position, clock_m, isb_m, usable):
    """Design, residuals and weights of epochs at ``position`` (E, 3) with the given clock and biases."""
    e = rho.shape[0]
    sat_safe = np.where(np.isfinite(sat), sat, np.array([3.0e7, 0.0, 0.0]))
    g, r = _design(sat_safe, position, system, n_systems)
    isb = np.zeros((e, n_systems))  # a fix of fewer systems has fewer biases: the rest are not used
    given = np.nan_to_num(np.asarray(isb_m, dtype=np.float64).reshape(e, -1))
    isb[:, 1:1 + given.shape[1]] = given[:, :n_systems - 1]
    pred = r + np.nan_to_num(np.asarray(clock_m, dtype=np.float64))[:, None] + np.take_along_axis(isb, system, axis=1)
    y = np.where(usable, rho - pred, 0.0)
    w = np.where(usable, 1.0 / np.where(usable, sig, 1.0) ** 2, 0.0)
    return g, y, w


def _without(sat, rho, sig, system, n_systems, start, j, k_axis, pfa):
    """Steps 1-4 on one epoch without satellite ``j``, its own fix iterated from ``start`` (a large fault
    pulls the all-in fix kilometres off, where one linear step from it would not reach the rest's solution);
    None when the rest gives no fix."""
    rho = rho.copy()
    rho[j] = np.nan
    usable = np.isfinite(rho) & np.isfinite(sig) & (sig > 0) & np.isfinite(sat).all(-1)
    fix = least_squares_position(sat[None], np.where(usable, rho, np.nan)[None], np.where(usable, sig, np.inf)[None],
                                 system, np.asarray(start, dtype=np.float64)[None], iterations=10)
    position = np.asarray(fix.position_m).reshape(1, 3)
    if not np.isfinite(position).all():
        return None
    g, y, w = _linearised(sat[None], rho[None], sig[None], system[None], n_systems, position, fix.clock_m[:1],
                          np.asarray(fix.isb_m)[:1], usable[None])
    sub = _separations(g, w, y, system[None], n_systems, k_axis, pfa)
    rot = np.swapaxes(_enu_rotation(position), -1, -2)[0]
    sub["position"] = position[0] + rot @ sub["x0"][0, :3]
    return sub


def _mdb(sep, p_md):
    k_md = stats.norm.isf(p_md)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_axis = np.where(sep["sens"] > 1e-12, (sep["thresh"] + k_md * sep["sig_ss"]) / sep["sens"], np.inf)
    return np.where(sep["used"], per_axis.min(axis=-1), np.nan)


def raim(satellite_m, pseudorange_m, sigma_m, system, x0_m, settings: RaimSettings | None = None) -> RaimResult:
    """Position-domain integrity (module docstring) of epochs of pseudoranges ``pseudorange_m`` (E, S)
    (corrected for satellite clock and atmosphere; NaN: not tracked) from satellites ``satellite_m`` (E, S, 3)
    ECEF with 1-sigma ``sigma_m`` (E, S) and system index ``system`` (S,) (0: the reference clock's);
    ``x0_m`` a coarse starting position (3,) or (E, 3)."""
    rho = np.asarray(pseudorange_m, dtype=np.float64)
    sat = np.broadcast_to(np.asarray(satellite_m, dtype=np.float64), rho.shape + (3,))
    sig = np.broadcast_to(np.asarray(sigma_m, dtype=np.float64), rho.shape)
    system = np.asarray(system, dtype=np.intp)
    # the satellites of each epoch packed to the front (the subset algebra is cubic in the columns)
    usable = np.isfinite(rho) & np.isfinite(sig) & (sig > 0) & np.isfinite(sat).all(-1)
    order = np.argsort(~usable, axis=1, kind="stable")
    width = max(int(usable.sum(axis=1).max(initial=0)), 1)
    cols = order[:, :width]
    take = lambda a: np.take_along_axis(a, cols if a.ndim == 2 else cols[..., None], axis=1)  # noqa: E731
    fix = least_squares_position(sat, np.where(usable, rho, np.nan), np.where(usable, sig, np.inf), system, x0_m,
                                 iterations=8)
    packed = _raim_packed(take(sat), np.where(take(usable), take(rho), np.nan), take(sig),
                          np.broadcast_to(system, rho.shape)[np.arange(rho.shape[0])[:, None], cols],
                          int(system.max(initial=0)) + 1, fix, x0_m, settings or RaimSettings())
    mdb = np.full(rho.shape, np.nan)
    np.put_along_axis(mdb, cols, packed.mdb_m, axis=1)
    excluded = np.where(packed.excluded >= 0, cols[np.arange(rho.shape[0]), np.maximum(packed.excluded, 0)], -1)
    return RaimResult(state=packed.state, position_m=packed.position_m, hpl_m=packed.hpl_m, vpl_m=packed.vpl_m,
                      excluded=excluded, n_used=packed.n_used, mdb_m=mdb, max_statistic=packed.max_statistic)


def _raim_packed(sat, rho, sig, system, n_systems, fix, x0_m, cfg) -> RaimResult:
    """:func:`raim` on columns packed per epoch (``system`` (E, S) per column), from the all-in ``fix``."""
    e, s = rho.shape
    position = np.asarray(fix.position_m)
    ok_fix = np.isfinite(position).all(-1)
    position = np.where(ok_fix[:, None], position, np.broadcast_to(np.asarray(x0_m, dtype=np.float64), (e, 3)))
    usable = np.isfinite(rho) & np.isfinite(sig) & (sig > 0) & np.isfinite(sat).all(-1) & ok_fix[:, None]
    # the unknowns of each epoch: position, clock and one bias per further system it has satellites of
    present = np.stack([(usable & (system == j)).any(-1) for j in range(n_systems)], -1)
    n_unknowns = 3 + np.maximum(present.sum(-1), 1)
    g, y, w = _linearised(sat, rho, sig, system, n_systems, position, fix.clock_m, fix.isb_m, usable)
    k_axis = cfg.k_axis
    sep = _separations(g, w, y, system, n_systems, k_axis, cfg.pfa)
    enu_to_ecef = np.swapaxes(_enu_rotation(position), -1, -2)
    out_pos = position + np.einsum("eij,ej->ei", enu_to_ecef, sep["x0"][:, :3])
    hpl, vpl = sep["hpl"].copy(), sep["vpl"].copy()
    excluded = np.full(e, -1, dtype=np.intp)
    n_used = sep["n_used"].copy()
    detectable = n_used >= n_unknowns + 1  # a fault can be detected (each subset still solvable)
    enough = n_used >= n_unknowns + 2  # and excluded (the rest can detect again)
    over_limits = lambda h, v: (h > cfg.horizontal_alert_limit_m) | (v > cfg.vertical_alert_limit_m)  # noqa: E731
    state = np.where(sep["alarm"], "alarm", "ok").astype(object)
    for k in np.flatnonzero(sep["alarm"] & enough):
        strength = np.where(sep["used"][k], (sep["ratio"][k]).max(-1), -np.inf)
        passing = []
        for j in np.argsort(-strength)[:MAX_EXCLUSION_CANDIDATES]:
            if not np.isfinite(strength[j]):
                break
            sub = _without(sat[k], rho[k], sig[k], system[k], n_systems, position[k], j, k_axis, cfg.pfa)
            if sub is not None and not sub["alarm"][0]:
                passing.append((j, sub))
        if len(passing) != 1:
            # none passes: not excludable; two or more: the fault is not identified (each rest, the faulty
            # satellite's among them, looks clean), and naming one would name the wrong one as often as not
            continue
        j, sub = passing[0]
        excluded[k] = j
        hpl[k], vpl[k], n_used[k] = sub["hpl"][0], sub["vpl"][0], sub["n_used"][0]
        out_pos[k] = sub["position"]
        # the fault found and left out; the rest's levels over a limit: still an alarm, the satellite named
        state[k] = "alarm" if over_limits(hpl[k], vpl[k]) else "excluded"
    over = over_limits(hpl, vpl)
    # detected with too few satellites to exclude: an alarm, never hidden as "unavailable"
    cannot = ~detectable | ~ok_fix | ((state == "ok") & (over | ~enough))
    state[cannot & ~((state == "alarm") & detectable & ok_fix)] = "unavailable"
    blind = ~detectable | ~ok_fix
    hpl[blind | ((state == "unavailable") & ~enough)], vpl[blind | ((state == "unavailable") & ~enough)] = math.inf, math.inf
    out_pos[~ok_fix] = np.nan
    max_stat = np.where(sep["used"][..., None], sep["ratio"], 0.0).max(axis=(1, 2))
    return RaimResult(state=state, position_m=out_pos, hpl_m=hpl, vpl_m=vpl, excluded=excluded, n_used=n_used,
                      mdb_m=_mdb(sep, cfg.p_md), max_statistic=max_stat)
