"""Tests of one whitened window of second differences: the chi-square omnibus and a GLR for fault onsets.

A window ``v`` of ``k`` second differences (the last ``k`` of an unbroken chain) is whitened by the leading
``k x k`` block of ``D = L^-1`` (``C = L L^T``, the window's covariance): ``w = D_k v``, i.i.d. N(0, kappa)
under H0 given the window's noise scale ``kappa`` (:mod:`chronofuse.integrity.station_noise`: ``kappa /
scale ~ nu / chi2(nu)``).

* **chi-square** (the patent's test): ``T = |w|^2``; ``T / (k scale) ~ F(k, nu)``, so
  ``p = F.sf(T / (k scale), k, nu)``.
* **GLR for onsets** (Basseville & Nikiforov, "Detection of Abrupt Changes", 1993, section 7.2): a fault
  of unknown size ``a`` with onset ``j`` in the window and shape ``s`` adds ``a s_j`` to ``v``, ``a D_k s_j``
  to ``w``. The log likelihood ratio maximised over ``a`` is ``g_j = (u_j . w)^2`` with ``u_j = D_k s_j /
  |D_k s_j|``; the statistic is ``G = max_j g_j`` over every onset in the window and every shape. The
  shapes, in the clock bias ``x`` and in its second difference ``d(k) = x(k) - 2x(k-1) + x(k-2)``:

  ==========  ==============================  ==============================
  shape       ``x`` from the onset ``j``      ``d`` from ``j``
  ==========  ==============================  ==============================
  step        a phase step, ``1``             ``1, -1, 0, ...``
  ramp        a frequency step, ``k - j``     ``1, 0, 0, ...`` (an impulse)
  drag        a frequency ramp, ``(k-j)^2/2`` ``1/2, 1, 1, ...`` (a step)
  ==========  ==============================  ==============================

  Each ``g_j / kappa`` is chi-square with one degree of freedom, so ``g_j / scale ~ F(1, nu)``; the
  ``J = 3 k`` onsets and shapes are combined by Boole's inequality, ``P(G > g) <= J F.sf(g / scale, 1, nu)``:
  ``p = min(1, J F.sf(G / scale, 1, nu))``, a valid bound however strongly the ``g_j`` are correlated
  (adjacent onsets are). For ``nu = inf`` (a Gaussian model) ``F(k, inf)`` is ``chi2(k) / k``.

Each test returns, for windows ``w`` (N, k) whitened with whiteners ``D`` (N, k, k), the statistic and its
tail probability; the window's last ``k`` rows are what :func:`signature_table` precomputes per whitener.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import special

__all__ = ["WINDOW_TESTS", "SHAPES", "signatures", "chi_square_test", "glr_test", "f_tail"]

#: Fault shapes of the GLR (module docstring): their signatures in the second difference from the onset.
SHAPES = ("step", "ramp", "drag")


def signatures(n: int) -> np.ndarray:
    """Unwhitened signatures ``s_j`` in a window of ``n`` differences: (3 n, n), onset ``j`` = row % n,
    shape = row // n in :data:`SHAPES` order (the rows of a shape whose pattern starts at ``j``)."""
    out = np.zeros((3 * n, n))
    for j in range(n):
        out[j, j] = 1.0
        if j + 1 < n:
            out[j, j + 1] = -1.0
        out[n + j, j] = 1.0
        out[2 * n + j, j] = 0.5
        out[2 * n + j, j + 1 :] = 1.0
    return out


def f_tail(x: np.ndarray, dof, tail_dof: float) -> np.ndarray:
    """``P(F(dof, nu) > x)``, with ``nu = inf`` read as ``chi2(dof) / dof`` (scipy's ``fdtrc``/``chdtrc`` ufuncs:
    the same values as ``stats.f.sf``/``stats.chi2.sf`` without their per-call overhead)."""
    if np.ndim(tail_dof) == 0:  # one tail for all (the identification's case): no broadcasting, one ufunc
        x = np.maximum(np.asarray(x, dtype=np.float64), 0.0)
        with np.errstate(invalid="ignore"):
            if math.isinf(tail_dof):
                return special.chdtrc(dof, x * np.asarray(dof, dtype=np.float64))
            return special.fdtrc(dof, float(tail_dof), x)
    x, dof, nu = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(dof, dtype=np.float64),
                                     np.asarray(tail_dof, dtype=np.float64))
    gauss = np.isinf(nu)
    with np.errstate(invalid="ignore"):
        out = special.fdtrc(dof, np.where(gauss, 1.0, nu), np.maximum(x, 0.0))
        if gauss.any():
            out = np.where(gauss, special.chdtrc(dof, np.maximum(x, 0.0) * dof), out)
    return out


def chi_square_test(w: np.ndarray, whiteners: np.ndarray, scale: float, tail_dof: float) -> tuple[np.ndarray, np.ndarray]:
    """``(T, p)`` of whitened windows ``w`` (N, k) (module docstring); ``whiteners`` is not used."""
    t = np.einsum("ij,ij->i", w, w)
    k = w.shape[1]
    return t, f_tail(t / (k * scale), k, tail_dof)


def glr_test(w: np.ndarray, whiteners: np.ndarray, scale: float, tail_dof: float) -> tuple[np.ndarray, np.ndarray]:
    """``(G, p)`` of whitened windows ``w`` (N, k) whitened by ``whiteners`` (N, k, k) (module docstring)."""
    n, k = w.shape
    if n == 0:
        return np.zeros(0), np.zeros(0)
    s = signatures(k)  # (3k, k)
    u = np.einsum("nij,sj->nsi", whiteners, s)  # (N, 3k, k) whitened signatures
    norm = np.sqrt(np.einsum("nsi,nsi->ns", u, u))
    proj = np.einsum("nsi,ni->ns", u, w) / np.where(norm > 0, norm, np.inf)
    g = np.max(proj**2, axis=1)
    return g, np.minimum(1.0, 3 * k * f_tail(g / scale, 1, tail_dof))


#: The window tests by name (the identification stage's ``test``).
WINDOW_TESTS = {"chi-square": chi_square_test, "glr": glr_test}
