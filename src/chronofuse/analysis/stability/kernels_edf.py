"""Greenhall's basic sum (eq. (10)) for every EDF row in one numba call.

:func:`chronofuse.analysis.stability.edf._basic_sum` is the numpy twin (the readable one, compared in the
tests). Both evaluate ``sz(j/S)**2`` for ``j = 0..J`` of each row from ``sw`` (eq. (7)), ``sx`` (eq. (8))
and ``sz`` (eq. (9)). The numpy version does it with some sixty array operations on arrays of a few
hundred elements, whose fixed cost is most of an EDF call: at 1e5 points and 15 octave taus, 80 us of
the 450 us a public ``adev`` call takes, against allantools' bare 500 us. This loop takes a few
microseconds. It adds the same terms in another order (the twin's ``@`` and ``einsum``) and forms
``|t|**(3 - alpha)`` by multiplication (an integer power: no ``pow`` call, which was most of its time),
so the EDFs agree to a few units in the 13th digit (the sums cancel), not bit for bit.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["basic_sums"]

_TINY = np.finfo(np.float64).tiny  # ln(tiny) is finite: |t|**p ln|t| stays 0 at t = 0


@numba.njit(cache=True, nogil=True, inline="always")
def _sw(t: float, alpha: int) -> float:
    """Eq. (7): ``-|t|, t**2 ln|t|, |t|**3, -t**4 ln|t|, -|t|**5, t**6 ln|t|, |t|**7`` for alpha = 2..-4."""
    a = abs(t)
    out = 1.0
    for _ in range(3 - alpha):  # |t|**(3 - alpha) by multiplication: an integer power, no pow() call
        out *= a
    if alpha % 2 != 0:  # odd alpha: the logarithmic kernels
        out *= math.log(max(a, _TINY))
    if alpha == 2 or alpha == -1 or alpha == -2:
        out = -out
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def _sx(t: float, f: float, alpha: int) -> float:
    """Eq. (8): ``F**2 [2 sw(t) - sw(t - 1/F) - sw(t + 1/F)]``, and ``sw(t, alpha + 2)`` where ``F = inf``."""
    if math.isinf(f):
        return _sw(t, alpha + 2)
    h = 1.0 / f
    return (_sw(t, alpha) * 2.0 - _sw(t - h, alpha) - _sw(t + h, alpha)) * (f * f)


@numba.njit(cache=True, nogil=True)
def basic_sums(J: np.ndarray, M: np.ndarray, S: np.ndarray, F: np.ndarray, alpha: np.ndarray, d: int,
               weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (10) per row, ``sz(0)**2 + 2 sum_{j=1}^{J-1} (1 - j/M) sz(j/S)**2 + (1 - J/M) sz(J/S)**2``, and
    ``sz(0)**2``. ``J`` (whole numbers >= 1), ``M``, ``S``, ``F``, ``alpha`` of shape (k,); ``weights``
    (2d+1,): ``(-1)**k C(2d, d+k)`` for ``k = -d..d`` (eq. (9))."""
    rows = J.size
    total = np.empty(rows)
    norm = np.empty(rows)
    for r in range(rows):
        last = int(J[r])
        m_terms, s, f, a = M[r], S[r], F[r], alpha[r]
        acc = 0.0
        for j in range(last + 1):
            t = j / s
            sz = 0.0
            for q in range(2 * d + 1):
                sz += weights[q] * _sx(t + (q - d), f, a)
            sz2 = sz * sz
            if j == 0:
                norm[r] = sz2
                acc += sz2
            elif j < last:
                acc += 2.0 * (1.0 - j / m_terms) * sz2
            else:
                acc += (1.0 - j / m_terms) * sz2
        total[r] = acc
    return total, norm


@numba.njit(cache=True, nogil=True)
def weighted_sz_sum(pairs: np.ndarray, S: float, F: float, alpha: int, d: int, weights: np.ndarray) -> tuple[float, float]:
    """``sum_j w_j sz(j/S)**2`` for ``j = 0..J`` with ``w_0 = pairs[0]``, ``w_j = 2 pairs[j]`` (0 < j < J) and
    ``w_J = pairs[J]`` (``J = pairs.size - 1``), and ``sz(0)**2``: the gap-aware twin of :func:`basic_sums`, whose
    weights ``M - j`` are the pair counts of a record without gaps. ``pairs`` (J + 1,): the number of pairs of
    terms kept ``j`` apart."""
    last = pairs.size - 1
    acc = 0.0
    norm = 0.0
    for j in range(last + 1):
        if pairs[j] == 0.0 and j > 0:
            continue
        t = j / S
        sz = 0.0
        for q in range(2 * d + 1):
            sz += weights[q] * _sx(t + (q - d), F, alpha)
        sz2 = sz * sz
        if j == 0:
            norm = sz2
            acc += pairs[0] * sz2
        elif j < last:
            acc += 2.0 * pairs[j] * sz2
        else:
            acc += pairs[j] * sz2
    return acc, norm


@numba.njit(cache=True, nogil=True)
def greenhall_rows(alpha: np.ndarray, m: np.ndarray, n_points: int, d: int, overlapping: bool, modified: bool,
                   weights: np.ndarray, table: np.ndarray, table3: np.ndarray, rho2: np.ndarray,
                   j_max: int) -> np.ndarray:
    """Greenhall's EDF of every row (``alpha``, ``m`` int64 (k,)) in one loop: the scalar twin of
    :func:`chronofuse.analysis.stability.edf.greenhall_edf`'s array code (the same cases, in the same
    order: Greenhall case 4 exact for white PM unmodified, Tables 1-3 for ``r > d + 1`` beyond ``J_max``
    terms, else eq. (10) over ``J`` terms or truncated to ``J_max`` at ``m' = J_max / r``). ``table``
    (7, 3, 2): Table 1 (modified) or 2 as indexed ``[2 - alpha, d - 1]``; ``table3`` (3, 2); ``rho2``
    (2d+1,): the squared autocorrelation of the binomial difference coefficients. NaN where ``M < 1``."""
    out = np.empty(alpha.size)
    b0 = table3[d - 1, 0]
    b1 = table3[d - 1, 1]
    for r in range(alpha.size):
        a = alpha[r]
        mf = float(m[r])
        S = mf if overlapping else 1.0
        L = mf * (d + 1) if modified else 1.0 + mf * d
        M = 1.0 + math.floor(S * (n_points - L) / mf)
        if M < 1.0:
            out[r] = np.nan
            continue
        J = min(M, (d + 1) * S)
        rr = M / S
        if not modified and a == 2:  # case 4, exact: M**2 rho0**2 / sum_p (M - |p| S)+ rho(p)**2
            total = 0.0
            for p in range(2 * d + 1):
                total += max(M - abs(p - d) * S, 0.0) * rho2[p]
            out[r] = M * M * rho2[d] / total
            continue
        summed = J <= j_max
        if not summed and rr > d + 1:  # Tables 1-3
            a0 = table[2 - a, d - 1, 0]
            a1 = table[2 - a, d - 1, 1]
            if not modified and a == 1:
                g = b0 + b1 * math.log(mf)
                out[r] = 1.0 / ((a0 - a1 / rr) / (g * g * rr))
            else:
                out[r] = 1.0 / ((a0 - a1 / rr) / rr)
            continue
        if modified:
            f = 1.0
        elif a > 0 or mf * (d + 1) <= j_max:
            f = mf
        else:
            f = np.inf
        last = int(J)
        Mb, Sb = M, S
        if not summed:  # eq. (10) truncated to J_max terms at m' = J_max / r
            m_prime = j_max / rr
            last = j_max
            Mb = float(j_max)
            Sb = m_prime
            if not modified:
                f = m_prime if a > 0 else np.inf
        acc = 0.0
        norm = 0.0
        for j in range(last + 1):
            t = j / Sb
            sz = 0.0
            for q in range(2 * d + 1):
                sz += weights[q] * _sx(t + (q - d), f, a)
            sz2 = sz * sz
            if j == 0:
                norm = sz2
                acc += sz2
            elif j < last:
                acc += 2.0 * (1.0 - j / Mb) * sz2
            else:
                acc += (1.0 - j / Mb) * sz2
        if not modified and not summed and a == 1:
            g = b0 + b1 * math.log(mf)
            norm = g * g
        out[r] = 1.0 / (acc / (norm * Mb))
    return out
