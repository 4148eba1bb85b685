"""Weighted least-squares position and clock from pseudoranges, batched over any leading axes.

Gauss–Newton on ``rho_n = |r_sat,n - r| + c dt + b_s(n) + e_n`` for ``(x, y, z, c dt, b_2 .. b_k)``: one
receiver clock plus one inter-system bias per system after the first (GPS-BDS time offset and receiver
delays), design row ``G_n = (-(r_sat,n - r)^T / |r_sat,n - r|, 1, [s(n) == j])`` and weights
``w_n = 1 / sigma_n^2`` (Misra & Enge 2011, section 6.1; Groves 2013, 9.4.1). A satellite with a NaN
pseudorange or zero weight takes no part. A system with no satellite at an epoch has its clock term
held at zero by one constraint row (as RTKLIB's single-point solution does), so an epoch needs
``3 + (systems present)`` satellites; with fewer it gives NaN. Dilution of precision from ``(G^T G)^-1`` in the local east-north-up frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pymap3d

__all__ = ["PositionFix", "least_squares_position"]


@dataclass(frozen=True)
class PositionFix:
    """Solutions over the leading axes ``(...)``: ``position_m`` (..., 3) ECEF, ``clock_m`` (...,) ``c dt``,
    ``isb_m`` (..., systems - 1), ``n_used`` (...,), DOPs ``gdop``, ``pdop``, ``hdop``, ``vdop``, ``tdop``
    (...,) and ``cov_enu_m2`` (..., 3, 3) the weighted position covariance in east-north-up."""

    position_m: np.ndarray
    clock_m: np.ndarray
    isb_m: np.ndarray
    n_used: np.ndarray
    gdop: np.ndarray
    pdop: np.ndarray
    hdop: np.ndarray
    vdop: np.ndarray
    tdop: np.ndarray
    cov_enu_m2: np.ndarray


def _enu_rotation(position_m: np.ndarray) -> np.ndarray:
    """Rows east, north, up of the local frame at ECEF positions (..., 3): shape (..., 3, 3)."""
    lat, lon, _ = pymap3d.ecef2geodetic(position_m[..., 0], position_m[..., 1], position_m[..., 2], deg=False)
    lat, lon = (np.asarray(a, dtype=np.float64).reshape(position_m.shape[:-1]) for a in (lat, lon))  # (1,) kept
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    z = np.zeros_like(lat)
    return np.stack([np.stack([-so, co, z], -1), np.stack([-sl * co, -sl * so, cl], -1),
                     np.stack([cl * co, cl * so, sl], -1)], -2)


def least_squares_position(satellite_m, pseudorange_m, sigma_m, system, x0_m, *, iterations: int = 6) -> PositionFix:
    """Batched WLS fixes.

    Parameters
    ----------
    satellite_m : array (..., S, 3)
        Satellite ECEF positions at emission (broadcast against the leading axes of ``pseudorange_m``).
    pseudorange_m : array (..., S)
        NaN where a satellite is not tracked.
    sigma_m : array (..., S)
        1-sigma of each pseudorange (m); weight ``1 / sigma^2``, ``inf`` or NaN drops the satellite.
    system : int array (S,)
        System index of each satellite, 0 for the reference system (its clock is ``clock_m``).
    x0_m : array (3,) or (..., 3)
        Starting position (a coarse prior: the scenario's area).
    """
    rho = np.asarray(pseudorange_m, dtype=np.float64)
    sat = np.broadcast_to(np.asarray(satellite_m, dtype=np.float64), rho.shape + (3,))
    system = np.asarray(system, dtype=np.intp)
    k = int(system.max()) + 1
    n_unknowns = 4 + (k - 1)
    w = 1.0 / np.asarray(sigma_m, dtype=np.float64) ** 2
    used = np.isfinite(rho) & np.isfinite(w) & (w > 0)
    used &= np.isfinite(sat).all(-1)
    w = np.where(used, w, 0.0)
    rho0 = np.where(used, rho, 0.0)
    # a satellite not used (NaN orbit, NaN range) must not reach the normal equations as 0 * NaN
    sat = np.where(used[..., None], sat, np.array([3.0e7, 0.0, 0.0]))
    lead = rho.shape[:-1]
    x = np.zeros(lead + (n_unknowns,))
    x[..., :3] = np.broadcast_to(np.asarray(x0_m, dtype=np.float64), lead + (3,))
    onehot = (system[:, None] == np.arange(1, k)[None, :]).astype(np.float64)  # (S, k-1)
    present = np.stack([(used & (system == j)).any(-1) for j in range(k)], -1)  # (..., k)
    enough = used.sum(-1) >= 3 + present.sum(-1)
    # absent systems: their clock term (the clock for system 0, its bias for the others) held at zero
    hold = np.zeros(lead + (n_unknowns, n_unknowns))
    idx = np.arange(3, n_unknowns)
    hold[..., idx, idx] = np.where(present, 0.0, 1.0)
    for _ in range(iterations):
        d = sat - x[..., None, :3]
        r = np.linalg.norm(d, axis=-1)
        g = np.concatenate([-d / r[..., None], np.ones(r.shape + (1,)), np.broadcast_to(onehot, r.shape + (k - 1,))], -1)
        predicted = r + x[..., 3:4] + (x[..., None, 4:] * onehot).sum(-1) if k > 1 else r + x[..., 3:4]
        resid = np.where(used, rho0 - predicted, 0.0)
        gw = g * w[..., None]
        normal = (np.swapaxes(gw, -1, -2) @ g + hold
                  + np.where(enough, 0.0, 1.0)[..., None, None] * np.eye(n_unknowns))
        rhs = np.einsum("...si,...s->...i", gw, resid)
        x = x + np.linalg.solve(normal, rhs[..., None])[..., 0]
    d = sat - x[..., None, :3]
    los = d / np.linalg.norm(d, axis=-1)[..., None]
    g = np.concatenate([-los, np.ones(los.shape[:-1] + (1,)), np.broadcast_to(onehot, los.shape[:-1] + (k - 1,))], -1)
    g_used = g * used[..., None]
    eye = hold + np.where(enough, 0.0, 1.0)[..., None, None] * np.eye(n_unknowns)
    unweighted = np.linalg.inv(np.swapaxes(g_used, -1, -2) @ g_used + eye)
    weighted = np.linalg.inv(np.swapaxes(g_used * w[..., None], -1, -2) @ g_used + eye)
    rot = _enu_rotation(np.where(enough[..., None], x[..., :3], np.asarray(x0_m, dtype=np.float64)))
    q_enu = rot @ unweighted[..., :3, :3] @ np.swapaxes(rot, -1, -2)
    cov = rot @ weighted[..., :3, :3] @ np.swapaxes(rot, -1, -2)
    nan = np.where(enough, 1.0, np.nan)
    return PositionFix(
        position_m=x[..., :3] * nan[..., None], clock_m=x[..., 3] * nan, isb_m=x[..., 4:] * nan[..., None],
        n_used=used.sum(-1), gdop=np.sqrt(np.trace(unweighted[..., :4, :4], axis1=-2, axis2=-1)) * nan,
        pdop=np.sqrt(np.trace(q_enu, axis1=-2, axis2=-1)) * nan,
        hdop=np.sqrt(q_enu[..., 0, 0] + q_enu[..., 1, 1]) * nan, vdop=np.sqrt(q_enu[..., 2, 2]) * nan,
        tdop=np.sqrt(unweighted[..., 3, 3]) * nan, cov_enu_m2=cov * nan[..., None, None])
