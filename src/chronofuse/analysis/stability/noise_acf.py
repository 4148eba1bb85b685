"""The lag-1 autocorrelation noise identification in numba (Riley & Greenhall 2004), for every factor at once.

The kernels behind :func:`~chronofuse.analysis.stability.noise_id.acf_noise_id_fast` and
:func:`~chronofuse.analysis.stability.noise_id.identify_noise_methods`; their readable numpy twin is
:func:`~chronofuse.analysis.stability.noise_id.acf_noise_id`, and the tests compare the two. The series is
the ``(d+1)``-th difference of the decimated phase ``x[::m]`` divided by ``m`` (the ``d``-times differenced
frequency averages), read block by block, never stored whole (Riley & Greenhall eqs. (2)-(6)).
"""

from __future__ import annotations

import numba
import numpy as np

from chronofuse.analysis.stability.kernels_differences import REASSOC

__all__ = ["MIN_ACF_POINTS", "DELTA_STATIONARY", "NO_ACF", "acf_alphas", "lag1_of_differences"]

# Riley & Greenhall (2004): the lag-1 ACF method needs about 30 points; Stable32 uses B1/R(n) below that.
MIN_ACF_POINTS = 30
# Stationarity threshold of the fractionally integrated noise, delta < 1/4 (Riley & Greenhall eq. (5)).
DELTA_STATIONARY = 0.25


_ACF_BLOCK = 1 << 14  # terms per block of a decimated record: its phase stays in the CPU cache
_ACF_WHOLE = 1 << 17  # a decimated record up to this many terms is gathered once for both passes


@numba.njit(cache=True, nogil=True, fastmath=REASSOC)
def _block_sums(p: np.ndarray, count: int, d: int, inv_m: float, w0: float, offset: int) -> tuple[float, float]:
    """``sum v`` and ``sum (offset + k) v`` over ``v = w_k - w0``, ``k < count``, where ``w`` is the
    ``(d+1)``-th difference of the phase ``p`` (count + d + 1,) divided by ``m``."""
    s1 = 0.0
    skw = 0.0
    if d == 0:
        a1, a0 = p[1 : count + 1], p[:count]
        for k in range(count):
            v = (a1[k] - a0[k]) * inv_m - w0
            s1 += v
            skw += (offset + k) * v
    elif d == 1:
        a2, a1, a0 = p[2 : count + 2], p[1 : count + 1], p[:count]
        for k in range(count):
            s1 += (a2[k] - 2.0 * a1[k] + a0[k]) * inv_m - w0
    elif d == 2:
        a3, a2, a1, a0 = p[3 : count + 3], p[2 : count + 2], p[1 : count + 1], p[:count]
        for k in range(count):
            s1 += (a3[k] - 3.0 * a2[k] + 3.0 * a1[k] - a0[k]) * inv_m - w0
    else:
        a4, a3, a2, a1, a0 = p[4 : count + 4], p[3 : count + 3], p[2 : count + 2], p[1 : count + 1], p[:count]
        for k in range(count):
            s1 += (a4[k] - 4.0 * a3[k] + 6.0 * a2[k] - 4.0 * a1[k] + a0[k]) * inv_m - w0
    return s1, skw


@numba.njit(cache=True, nogil=True, fastmath=REASSOC)
def _block_products(p: np.ndarray, count: int, d: int, inv_m: float, mean: float, slope: float, centre: float,
                    prev: float) -> tuple[float, float, float]:
    """Energy and lag-1 products of the residuals ``e_k = w_k - mean - slope (k - centre)``, ``k < count``
    (``w`` as in :func:`_block_sums`), continuing from the residual ``prev`` before the block; returns
    ``(sum e**2, sum prev e, last e)``."""
    den = 0.0
    num = 0.0
    for k in range(count):
        if d == 0:
            w = (p[k + 1] - p[k]) * inv_m
        elif d == 1:
            w = (p[k + 2] - 2.0 * p[k + 1] + p[k]) * inv_m
        elif d == 2:
            w = (p[k + 3] - 3.0 * p[k + 2] + 3.0 * p[k + 1] - p[k]) * inv_m
        else:
            w = (p[k + 4] - 4.0 * p[k + 3] + 6.0 * p[k + 2] - 4.0 * p[k + 1] + p[k]) * inv_m
        e = w - mean - slope * (k - centre)
        den += e * e
        num += prev * e
        prev = e
    return den, num, prev


@numba.njit(cache=True, nogil=True)
def _decimated(x: np.ndarray, m: int, start: int, size: int, scratch: np.ndarray) -> np.ndarray:
    """``x[::m][start : start + size]`` as a contiguous array: a view when ``m == 1``, else copied into
    ``scratch``."""
    if m == 1:
        return x[start : start + size]
    base = start * m
    for q in range(size):
        scratch[q] = x[base + q * m]
    return scratch[:size]


@numba.njit(cache=True, nogil=True, fastmath=REASSOC)  # reassociated sums: vectorized reductions; the tests compare the twin
def lag1_of_differences(x: np.ndarray, m: int, d: int, inv_m: float) -> float:
    """Lag-1 autocorrelation of the ``d``-times differenced frequency averages at factor ``m``.

    The numba twin of ``noise_id.lag1_autocorrelation`` applied to ``noise_id._remove_linear(frequency_averages(x, m))``
    differenced ``d`` times (d = 0), or to the plain ``d``-fold difference (d >= 1: differencing removes
    the line's offset and turns its slope into a constant, which the mean removal takes away). The
    series ``w`` is the ``(d+1)``-th difference of the decimated phase ``x[::m]`` divided by ``m``,
    formed on the fly twice: once for its sums (mean and slope), once for the residuals' energy and
    lag-1 products. ``inv_m`` is the ``1/m`` of the frequency averages (``x`` may be a record already
    decimated by a factor of the averaging factor, with ``m`` the rest). The decimated phase is read block
    by block (a view of ``x`` at ``m = 1``): no array of the record's size is allocated (at 1e7 points that
    allocation and its page faults cost more than the arithmetic).
    """
    n = (x.size - 1) // m - d  # terms of w
    if n < 2:
        return 0.0
    block = n if n + d + 1 <= _ACF_WHOLE else _ACF_BLOCK
    gathered = m > 1 and block == n  # the whole decimated record in scratch, gathered once
    scratch = np.empty(block + d + 1) if m > 1 else np.empty(0)
    if gathered:
        _decimated(x, m, 0, n + d + 1, scratch)
    p = scratch if gathered else _decimated(x, m, 0, d + 2, scratch)
    w0 = _block_sums(p, 1, d, inv_m, 0.0, 0)[0]
    s1 = 0.0
    skw = 0.0
    for start in range(0, n, block):
        count = min(block, n - start)
        p = scratch[: count + d + 1] if gathered else _decimated(x, m, start, count + d + 1, scratch)
        a, b = _block_sums(p, count, d, inv_m, w0, start)
        s1 += a
        skw += b
    half = 0.5 * (n - 1)
    mean = w0 + s1 / n
    slope = 0.0
    if d == 0:  # only the d = 0 series is detrended; the others need just their mean
        slope = (skw - half * s1) / (n * (n * n - 1.0) / 12.0)
    # Residuals e_k = w_k - mean - slope (k - half): energy and lag-1 products, carried across blocks.
    prev = w0 - mean + slope * half
    den = prev * prev
    num = 0.0
    for start in range(0, n, block):
        first = 1 if start == 0 else 0
        count = min(block, n - start) - first
        if gathered:
            p = scratch[first : first + count + d + 1]
        else:
            p = _decimated(x, m, start + first, count + d + 1, scratch)
        a, b, prev = _block_products(p, count, d, inv_m, mean, slope, half - start - first, prev)
        den += a
        num += b
    if den == 0.0:
        return 0.0
    return num / den


# acf_alphas' mark for a factor with fewer than MIN_ACF_POINTS frequency averages (no ACF answer).
NO_ACF = np.iinfo(np.int64).min


@numba.njit(cache=True, nogil=True)
def acf_alphas(x: np.ndarray, m: np.ndarray, dmax: int) -> np.ndarray:
    """``noise_id.acf_noise_id`` at every factor of ``m`` (k,) in one call: alpha (k,), ``NO_ACF`` where there
    are fewer than ``MIN_ACF_POINTS`` frequency averages (``np.rint`` rounds half to even, as ``round``)."""
    out = np.empty(m.size, dtype=np.int64)
    source = x  # the last decimated phase x[::source_m] gathered whole, to decimate further from
    source_m = 1
    for j in range(m.size):
        mj = m[j]
        if (x.size - 1) // mj < MIN_ACF_POINTS:
            out[j] = NO_ACF
            continue
        if mj % source_m != 0:
            source = x
            source_m = 1
        rest = mj // source_m
        if rest > 1 and (source.size - 1) // rest + 1 <= _ACF_WHOLE:  # x[::mj], from the smallest source
            source = np.ascontiguousarray(source[::rest])
            source_m = mj
            rest = 1
        d = 0
        while True:
            r1 = lag1_of_differences(source, rest, d, 1.0 / mj)
            delta = r1 / (1.0 + r1)
            if delta < DELTA_STATIONARY or d >= dmax:
                out[j] = int(-np.rint(2.0 * delta)) - 2 * d
                break
            d += 1
    return out
