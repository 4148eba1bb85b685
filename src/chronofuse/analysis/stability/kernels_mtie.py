"""MTIE's sparse table in numba: the first levels built block by block in cache, every loop vectorized.

The algorithm is the sparse table of :mod:`chronofuse.analysis.stability.kernels_tie` (window extrema by
doubling: ``hi_k[i] = max(x[i : i + 2**k])``, and a window of ``L`` samples, ``2**k <= L < 2**(k+1)``, is
covered by two windows of ``2**k``). Built level by level over the whole record, each level is one sweep
of two record-sized arrays through memory: at 1e7 samples and octave windows, 23 sweeps of 160 MB.

Phase 1: the levels ``0..top`` are built one block of ``block`` start positions at a time, in buffers
that hold the block and the ``2**(top + 1)`` samples after it (the reach of a level-``top`` window read
at a shift below ``2**top``). The block's windows shorter than ``2**(top + 1)`` are answered from the
buffers while they are in cache, and only the block's level-``top`` extrema are kept for phase 2.

Phase 2: the longer windows, level by level over the whole record, in chunks of at most ``2**k``
positions: a chunk's windows of level ``k`` are answered, then the chunk is raised to level ``k + 1``
in place. A chunk's reads ahead (``i + 2**k``, ``i + shift``) are not yet raised, because chunks go in
ascending order and a chunk is no longer than ``2**k``, so the record is swept once per level.

What makes the loops vectorize (SIMD), which the earlier version's did not: a level is built from one
pair of buffers into the other (phase 1) or chunk by chunk where writes and reads do not overlap
(phase 2), so the compiler's run-time overlap check passes; the window ranges are written to a scratch
array and their largest value taken over eight running maxima (one running maximum is a chain of
dependent comparisons); and a missing sample (NaN) enters the maxima as ``-inf`` and the minima as
``+inf``, which is exactly what ignoring it (``np.fmax``/``np.fmin``) gives, instead of a test per
comparison. A window of only NaN then has the range ``-inf - inf = -inf`` and never raises a maximum, so
MTIE is NaN where no window holds a sample.

Every extremum is the same comparison of the same two numbers as in the level-by-level sweep, and the
largest of the same set of ranges, so the result is bit-identical (tests compare it with the numpy twin
and the window scan, with and without NaN, at block sizes that cut the record anywhere).
"""

from __future__ import annotations

import numba
import numpy as np

#: Start positions per block and the highest level built in cache: four buffers of (2**15 + 2**13)
#: float64 (two levels of maxima and of minima), 4 x 320 KiB.
BLOCK = 1 << 15
TOP_LEVEL = 12
#: Positions per chunk in phase 2: the chunk and the two stretches it reads ahead stay in cache between
#: its windows' ranges and its rise to the next level.
CHUNK = 1 << 12

__all__ = ["BLOCK", "TOP_LEVEL", "CHUNK", "mtie_blocked"]


@numba.njit(cache=True, nogil=True, inline="always")
def _max_into(out: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    """``out[i] = max(a[i], b[i])``, the first operand on ties (``a if a > b else b``)."""
    for i in range(out.size):
        p = a[i]
        q = b[i]
        out[i] = p if p > q else q


@numba.njit(cache=True, nogil=True, inline="always")
def _min_into(out: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
    """``out[i] = min(a[i], b[i])``, the first operand on ties."""
    for i in range(out.size):
        p = a[i]
        q = b[i]
        out[i] = p if p < q else q


@numba.njit(cache=True, nogil=True, inline="always")
def _next_level(hi: np.ndarray, lo: np.ndarray, up_hi: np.ndarray, up_lo: np.ndarray, size: int, k: int) -> None:
    """Level ``k + 1`` of the first ``size`` samples' buffers ``hi``/``lo`` (level ``k``) into the other pair."""
    count = size - (2 << k) + 1
    if count > 0:
        _max_into(up_hi[:count], hi[:count], hi[1 << k : (1 << k) + count])
        _min_into(up_lo[:count], lo[:count], lo[1 << k : (1 << k) + count])


@numba.njit(cache=True, nogil=True)
def _largest(t: np.ndarray, peak: float) -> float:
    """``max(peak, max(t))`` for ``t`` without NaN, by halving ``t`` in place (scratch): each pass takes the
    larger of the first half and the last, two stretches that do not overlap, so it vectorizes (one
    running maximum is a chain of dependent comparisons, which does not)."""
    size = t.size
    while size > 1:
        half = size // 2
        _max_into(t[:half], t[:half], t[size - half : size])
        size -= half
    if t.size and t[0] > peak:
        peak = t[0]
    return peak


@numba.njit(cache=True, nogil=True)
def _largest_range(hi: np.ndarray, lo: np.ndarray, count: int, shift: int, peak: float, tie: np.ndarray) -> float:
    """``peak`` raised to the largest ``max(hi[i], hi[i + shift]) - min(lo[i], lo[i + shift])`` of
    ``i < count`` (level-``k`` arrays, windows of ``2**k + shift`` samples); ``tie`` is scratch."""
    for s in range(0, count, tie.size):
        e = min(s + tie.size, count)
        size = e - s
        a, b = hi[s:e], hi[s + shift : e + shift]
        c, d = lo[s:e], lo[s + shift : e + shift]
        t = tie[:size]
        for i in range(size):
            p, q, u, v = a[i], b[i], c[i], d[i]
            r = (p if p > q else q) - (u if u < v else v)
            t[i] = r if r == r else -np.inf  # inf - inf (infinite samples) never wins, as NaN
        peak = _largest(t, peak)
    return peak


@numba.njit(cache=True, nogil=True)
def _load_level0(x: np.ndarray, start: int, hi: np.ndarray, lo: np.ndarray, size: int, has_nan: bool) -> None:
    """``hi[:size] = lo[:size] = x[start : start + size]``, a NaN as ``-inf`` in ``hi`` and ``+inf`` in ``lo``."""
    src, h, low = x[start : start + size], hi[:size], lo[:size]
    if has_nan:
        for i in range(size):
            v = src[i]
            h[i] = -np.inf if v != v else v
            low[i] = np.inf if v != v else v
    else:
        h[:] = src
        low[:] = src


@numba.njit(cache=True, nogil=True)
def mtie_blocked(x: np.ndarray, window: np.ndarray, order: np.ndarray, has_nan: bool, block: int,
                 top: int) -> np.ndarray:
    """MTIE (k,) for windows of ``window`` (k,) samples (each ``2 <= window <= x.size``), visited in
    increasing ``order``; levels ``0..top`` in blocks of ``block`` start positions (module docstring)."""
    n = x.size
    out = np.full(window.size, np.nan)
    peaks = np.full(window.size, -np.inf)
    if window.size == 0:
        return out
    longest = window[order[order.size - 1]]
    while top > 0 and (1 << top) > longest:  # no level above the longest window's
        top -= 1
    reach = 1 << (top + 1)
    tie = np.empty(min(block, n))
    a_hi, a_lo = np.empty(block + reach), np.empty(block + reach)
    b_hi, b_lo = np.empty(block + reach), np.empty(block + reach)
    longer = longest >= reach  # phase 2 needed: keep level `top` of the whole record
    hi = np.empty(n if longer else 0)
    lo = np.empty(n if longer else 0)
    # Phase 1: windows shorter than 2**(top + 1), block by block; level `top` kept for phase 2.
    for s in range(0, n, block):
        size = min(block + reach, n - s)
        _load_level0(x, s, a_hi, a_lo, size, has_nan)
        k = 0
        for idx in range(order.size):
            j = order[idx]
            length = window[j]
            if length >= reach:
                break
            while (1 << (k + 1)) <= length:
                _next_level(a_hi, a_lo, b_hi, b_lo, size, k)
                a_hi, b_hi, a_lo, b_lo = b_hi, a_hi, b_lo, a_lo
                k += 1
            stop = min(block, n - length + 1 - s)  # windows of this block that fit in the record
            if stop > 0:
                peaks[j] = _largest_range(a_hi, a_lo, stop, length - (1 << k), peaks[j], tie)
        if longer:
            while k < top:
                _next_level(a_hi, a_lo, b_hi, b_lo, size, k)
                a_hi, b_hi, a_lo, b_lo = b_hi, a_hi, b_lo, a_lo
                k += 1
            keep = min(block, size)
            hi[s : s + keep] = a_hi[:keep]
            lo[s : s + keep] = a_lo[:keep]
    # Phase 2: the longer windows, level by level over the whole record, chunk by chunk.
    idx = 0
    while idx < order.size and window[order[idx]] < reach:
        idx += 1
    k = top
    while idx < order.size:
        first = idx  # this level's windows: 2**k <= length < 2**(k + 1)
        while idx < order.size and window[order[idx]] < (2 << k):
            idx += 1
        rise = idx < order.size  # a longer window remains: raise the record to level k + 1
        count_up = n - (2 << k) + 1
        last = max(n - window[order[first]] + 1 if first < idx else 0, count_up if rise else 0)
        step = min(CHUNK, tie.size, 1 << k)
        for s in range(0, last, step):
            e = min(s + step, last)
            for q in range(first, idx):
                j = order[q]
                stop = min(e, n - window[j] + 1)
                if stop > s:
                    peaks[j] = _largest_range(hi[s:], lo[s:], stop - s, window[j] - (1 << k), peaks[j], tie)
            stop = min(e, count_up)
            if rise and stop > s:
                _max_into(hi[s:stop], hi[s:stop], hi[s + (1 << k) : stop + (1 << k)])
                _min_into(lo[s:stop], lo[s:stop], lo[s + (1 << k) : stop + (1 << k)])
        k += 1
    for j in range(window.size):
        if not (has_nan and peaks[j] == -np.inf):
            out[j] = peaks[j]
    return out
