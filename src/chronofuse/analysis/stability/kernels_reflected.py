"""The reflected, detrended subsequence sum behind MTOTDEV and HTOTDEV (NIST SP 1065 eq. (27)).

One idea: ``reflected_sum_of_squares(values, m, is_prefix)`` sums, over every subsequence of 3m
samples, the 6m squared second differences of window sums of its detrended, evenly reflected
extension; :mod:`chronofuse.analysis.stability.kernels_total` normalises it into MTOTDEV, TTOTDEV and
HTOTDEV. ``reflected_sum_of_squares_numpy`` is its readable twin, built sample by sample from the
definition, which the tests compare against.

The fast kernel. The even reflection of a subsequence ``z`` (length W = 3m) is one
period of the 2W-periodic sequence ``p = [reversed z, z]``, and the 6m terms of eq. (27) are the
squared third differences, at lag m, of the running sum ``C`` of ``p`` over exactly that period.
Each ``C(n)`` is a signed sum of at most three values of the prefix sum ``P`` of the series (of x for
MTOTDEV; for HTOTDEV ``P = x / tau0`` is already the prefix sum of y) minus ``slope * C_line(n)``,
where ``C_line`` is the same construction on the ramp 0, 1, ..., W-1 (closed form): every term
costs O(1). The terms are symmetric, ``d(j) == d(W - j mod 2W)``, so only W + 1 of the 2W are
computed. Prefix sums are built per block of subsequences after removing the block's end-to-end line
(the statistics are exactly invariant to it), so they stay small and no precision is lost to
cancellation. The subsequence index runs innermost (contiguous, vectorised loads), blocks run in
parallel. Cost: about (N - 3m) * 3m multiply-adds per averaging factor, half the terms
allantools evaluates one by one in Python.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["reflected_sum_of_squares", "reflected_sum_of_squares_numpy"]

# Floating-point reassociation lets LLVM vectorise the inner sums; NaN/Inf semantics are kept.
_FASTMATH = {"reassoc", "contract", "nsz", "arcp"}


@numba.njit(cache=True)
def _ramp_sum(k: int) -> float:
    """Sum of the ramp 0, 1, ..., k-1: k (k - 1) / 2 (exact in float64 for k < 2**26)."""
    return 0.5 * k * (k - 1)


@numba.njit(cache=True)
def _term_coefficients(j: int, m: int):
    """Coefficients of the j-th third difference ``-C(j) + 3C(j+m) - 3C(j+2m) + C(j+3m)``.

    ``C(n)`` is the running sum of the 2W-periodic even reflection ``[reversed z, z]`` of one
    subsequence ``z`` (W = 3m), written with ``K(k) = P[i+k] - P[i]``:
    ``n <= W: K(W) - K(W-n)``; ``W < n <= 2W: K(W) + K(n-W)``; ``2W < n < 3W: 3K(W) - K(3W-n)``.
    Returns ``(a_w, a_0, offsets (4,), signs (4,), ramp)``: the term is
    ``a_w P[i+W] + a_0 P[i] + sum_r signs[r] P[i+offsets[r]] - slope_i * ramp``.
    """
    w = 3 * m
    a_w = 0.0
    a_0 = 0.0
    offsets = np.empty(4, dtype=np.int64)
    signs = np.empty(4)
    ramp = 0.0
    weights = (-1.0, 3.0, -3.0, 1.0)
    for r in range(4):
        c = weights[r]
        n = j + r * m
        if n <= w:
            a_w += c
            offsets[r] = w - n
            signs[r] = -c
            ramp += c * (_ramp_sum(w) - _ramp_sum(w - n))
        elif n <= 2 * w:
            a_w += c
            a_0 -= 2.0 * c
            offsets[r] = n - w
            signs[r] = c
            ramp += c * (_ramp_sum(w) + _ramp_sum(n - w))
        else:
            a_w += 3.0 * c
            a_0 -= 2.0 * c
            offsets[r] = 3 * w - n
            signs[r] = -c
            ramp += c * (3.0 * _ramp_sum(w) - _ramp_sum(3 * w - n))
    return a_w, a_0, offsets, signs, ramp


@numba.njit(cache=True)
def _half_period(m: int):
    """Term offsets j covering one period once up to the symmetry ``d(j) == d(W - j mod 2W)``.

    Returns ``(j (J,), weight (J,))``: weight 2 for a pair, 1 for a self-symmetric offset.
    """
    w = 3 * m
    half = w // 2
    js = np.empty(w + 2, dtype=np.int64)
    wt = np.empty(w + 2)
    k = 0
    for j in range(0, half + 1):  # pairs (j, W - j) inside [0, W]
        js[k] = j
        wt[k] = 1.0 if 2 * j == w else 2.0
        k += 1
    for u in range(1, half + 1):  # pairs (W + u, 2W - u) inside [W + 1, 2W - 1]
        if 2 * u > w:
            break
        js[k] = w + u
        wt[k] = 1.0 if 2 * u == w else 2.0
        k += 1
    return js[:k], wt[:k]


@numba.njit(cache=True)
def _coefficient_table(m: int):
    """Coefficients of every needed term offset: ``(a_w (J,), a_0 (J,), offsets (J, 4), signs (J, 4), ramp (J,), weight (J,))``."""
    js, weight = _half_period(m)
    n_j = js.size
    a_w = np.empty(n_j)
    a_0 = np.empty(n_j)
    offsets = np.empty((n_j, 4), dtype=np.int64)
    signs = np.empty((n_j, 4))
    ramp = np.empty(n_j)
    for q in range(n_j):
        a_w[q], a_0[q], offsets[q], signs[q], ramp[q] = _term_coefficients(js[q], m)
    return a_w, a_0, offsets, signs, ramp, weight


@numba.njit(cache=True, fastmath=False)  # explicit: callees inherit the caller's fastmath otherwise
def _local_prefix(values: np.ndarray, start: int, n_prefix: int, is_prefix: bool) -> np.ndarray:
    """Prefix sums (n_prefix,) of one block, rebased so that its values stay small.

    ``is_prefix``: ``values`` already holds prefix sums (take ``values[start : start + n_prefix]``
    minus the line through its ends, i.e. remove a constant from the underlying samples); otherwise
    ``values`` holds samples (cumulate ``values[start : start + n_prefix - 1]`` minus the line through
    its ends). Both changes leave every detrended subsequence unchanged (the half-average slope of a
    line is exact), and keep the prefix sums small, which preserves precision.
    """
    q = np.empty(n_prefix)
    if is_prefix:
        base = values[start]
        step = (values[start + n_prefix - 1] - base) / (n_prefix - 1)
        for k in range(n_prefix):
            q[k] = (values[start + k] - base) - step * k
        return q
    n_samples = n_prefix - 1
    base = values[start]
    step = (values[start + n_samples - 1] - base) / (n_samples - 1)
    acc = 0.0
    q[0] = 0.0
    for k in range(n_samples):
        acc += (values[start + k] - base) - step * k
        q[k + 1] = acc
    return q


@numba.njit(cache=True, fastmath=_FASTMATH)
def _block_sum(values, start, count, m, is_prefix, a_w, a_0, offsets, signs, ramp, weight) -> float:
    """The sum of :func:`reflected_sum_of_squares` over subsequences ``start .. start + count - 1``."""
    w = 3 * m
    h = w // 2
    hp = w - h
    p = _local_prefix(values, start, count + w, is_prefix)
    # Shifted views indexed by the bare loop counter: the compiler then knows every index is
    # non-negative and emits contiguous vector loads (``p[i + o]`` would need a wraparound check).
    p_w, p_h, p_hp = p[w:], p[h:], p[hp:]
    slope = np.empty(count)
    for i in range(count):  # (mean of last half - mean of first half) / distance between them
        slope[i] = ((p_w[i] - p_hp[i]) - (p_h[i] - p[i])) / (h * hp)
    total = 0.0
    n_q = a_w.size
    q = 0
    while q < n_q:
        # One of a_w, a_0 is always zero (offsets j <= W touch P[i+W] with weights summing to zero,
        # the others P[i]): load only the other one. Two offsets sharing it are done in one pass.
        on_w = a_w[q] != 0.0
        base = p_w if on_w else p
        c_a = a_w[q] if on_w else a_0[q]
        r_a = ramp[q]
        a0, a1, a2, a3 = signs[q, 0], signs[q, 1], signs[q, 2], signs[q, 3]
        u0, u1, u2, u3 = p[offsets[q, 0] :], p[offsets[q, 1] :], p[offsets[q, 2] :], p[offsets[q, 3] :]
        if q + 1 < n_q and (a_w[q + 1] != 0.0) == on_w:
            c_b = a_w[q + 1] if on_w else a_0[q + 1]
            r_b = ramp[q + 1]
            b0, b1, b2, b3 = signs[q + 1, 0], signs[q + 1, 1], signs[q + 1, 2], signs[q + 1, 3]
            v0, v1 = p[offsets[q + 1, 0] :], p[offsets[q + 1, 1] :]
            v2, v3 = p[offsets[q + 1, 2] :], p[offsets[q + 1, 3] :]
            acc_a = 0.0
            acc_b = 0.0
            for i in range(count):
                g = base[i]
                sl = slope[i]
                t_a = c_a * g + a0 * u0[i] + a1 * u1[i] + a2 * u2[i] + a3 * u3[i] - r_a * sl
                t_b = c_b * g + b0 * v0[i] + b1 * v1[i] + b2 * v2[i] + b3 * v3[i] - r_b * sl
                acc_a += t_a * t_a
                acc_b += t_b * t_b
            total += weight[q] * acc_a + weight[q + 1] * acc_b
            q += 2
        else:
            acc_a = 0.0
            for i in range(count):
                t_a = c_a * base[i] + a0 * u0[i] + a1 * u1[i] + a2 * u2[i] + a3 * u3[i] - r_a * slope[i]
                acc_a += t_a * t_a
            total += weight[q] * acc_a
            q += 1
    return total


@numba.njit(cache=True, parallel=True)
def _block_sums_parallel(values, n_sub, block, m, is_prefix, a_w, a_0, offsets, signs, ramp, weight):
    n_blocks = (n_sub + block - 1) // block
    partial = np.zeros(n_blocks)
    for b in numba.prange(n_blocks):
        count = min(block, n_sub - b * block)
        partial[b] = _block_sum(values, b * block, count, m, is_prefix, a_w, a_0, offsets, signs, ramp, weight)
    return partial


@numba.njit(cache=True)
def _block_sums_serial(values, n_sub, block, m, is_prefix, a_w, a_0, offsets, signs, ramp, weight):
    n_blocks = (n_sub + block - 1) // block
    partial = np.zeros(n_blocks)
    for b in range(n_blocks):
        count = min(block, n_sub - b * block)
        partial[b] = _block_sum(values, b * block, count, m, is_prefix, a_w, a_0, offsets, signs, ramp, weight)
    return partial


# Below this many terms a parallel region costs more than it saves (and much more on a loaded machine).
_PARALLEL_MIN_TERMS = 4_000_000


def reflected_sum_of_squares(values: np.ndarray, m: int, is_prefix: bool) -> float:
    """Sum over all subsequences and all 6m offsets of the squared second difference of window SUMS.

    ``values``: the L samples of a series (phase for MTOTDEV), shape (L,), or, with ``is_prefix``,
    its L + 1 prefix sums (phase / tau0 is the prefix sum of the frequency, for HTOTDEV). For each of
    the L - 3m + 1 subsequences of W = 3m samples: remove the half-average linear trend, reflect evenly
    to 9m samples, and sum ``(S1 - 2 S2 + S3)^2`` over the 6m offsets j, S1..S3 being the sums of the
    three consecutive m-sample windows starting at j: NIST SP 1065 eq. (27) and the Hadamard total
    variance, without their normalisation. Each term is O(1) from block-local prefix sums; O((L - 3m) * 3m)
    in all, blocks of subsequences in parallel when the work is large (the block size does not depend on
    the thread count, so neither does the result).
    """
    m = int(m)
    n_sub = values.size - 3 * m if is_prefix else values.size - 3 * m + 1
    tables = _coefficient_table(m)
    block = min(4096, max(256, n_sub // 8))
    driver = _block_sums_parallel if n_sub * tables[0].size >= _PARALLEL_MIN_TERMS else _block_sums_serial
    return float(np.sum(driver(values, n_sub, block, m, is_prefix, *tables)))


def reflected_sum_of_squares_numpy(series: np.ndarray, m: int) -> float:
    """Numpy twin of :func:`reflected_sum_of_squares`, built sample by sample from the definition.

    ``series`` (L,): the samples themselves (phase for MTOTDEV, frequency for HTOTDEV). Follows
    SP 1065 eq. (27) and allantools' ``calc_mtotdev_phase`` step by step: detrend, reflect to 9m,
    sum the 6m squared second differences of window sums.
    """
    w = 3 * m
    h, hp = w // 2, w - w // 2
    ramp = np.arange(w, dtype=float)
    total = 0.0
    for i in range(series.size - w + 1):
        z = series[i : i + w]
        slope = (z[hp:].mean() - z[:h].mean()) / hp
        z = z - slope * ramp
        xstar = np.concatenate((z[::-1], z, z[::-1]))
        c = np.concatenate(([0.0], np.cumsum(xstar)))
        j = np.arange(6 * m)
        s1 = c[j + m] - c[j]
        s2 = c[j + 2 * m] - c[j + m]
        s3 = c[j + 3 * m] - c[j + 2 * m]
        total += np.sum((s1 - 2.0 * s2 + s3) ** 2)
    return total
