"""MTIE's sparse table in numba, the first levels built block by block in cache.

The algorithm is the sparse table of :mod:`chronofuse.analysis.stability.kernels_tie` (window extrema by
doubling: ``hi_k[i] = max(x[i : i + 2**k])``, and a window of ``L`` samples, ``2**k <= L < 2**(k+1)``, is
covered by two windows of ``2**k``). Built level by level over the whole record, each level is one sweep
of two record-sized arrays through memory: at 1e7 samples and octave windows, 23 sweeps of 160 MB, and
the time goes to memory traffic, not to comparisons.

Here the levels ``0..top`` are built one block of ``block`` start positions at a time, in a buffer that
holds the block and the ``2**(top + 1)`` samples after it (the reach of a level-``top`` window read at
a shift below ``2**top``): the block's windows shorter than ``2**(top + 1)`` are answered from the buffer
while it is in cache, and only its level-``top`` extrema are written back. The record then goes through
memory once for those ``top + 1`` levels instead of ``top + 1`` times; the higher levels continue in
place over the whole record as before. Every extremum is the same comparison of the same two numbers as
in the level-by-level sweep, so the result is bit-identical (tests compare it with the unblocked sweep,
the numpy twin and the window scan, with and without NaN, at block sizes that cut the record anywhere).

Why a block can be written back in place: block ``s`` reads ``hi[s : s + block + 2**(top + 1)]`` and
writes ``hi[s : s + block]``; blocks go in ascending order, so what it reads beyond its own block is
still level 0 (the record itself), as the sweep needs.
"""

from __future__ import annotations

import numba
import numpy as np

#: Start positions per block and the highest level built in cache: buffers of (2**15 + 2**13) float64
#: for the maxima and the minima, 2 x 320 KiB (within a core's L2 cache on current x86 parts).
BLOCK = 1 << 15
TOP_LEVEL = 12

__all__ = ["BLOCK", "TOP_LEVEL", "mtie_blocked"]


@numba.njit(cache=True, nogil=True, inline="always")
def _hi(a: float, b: float, has_nan: bool) -> float:
    """The larger of ``a`` and ``b``; with ``has_nan``, a NaN operand is ignored (``np.fmax``)."""
    if has_nan:
        if a != a:
            return b
        if b != b:
            return a
    return a if a > b else b


@numba.njit(cache=True, nogil=True, inline="always")
def _lo(a: float, b: float, has_nan: bool) -> float:
    """The smaller of ``a`` and ``b``; with ``has_nan``, a NaN operand is ignored (``np.fmin``)."""
    if has_nan:
        if a != a:
            return b
        if b != b:
            return a
    return a if a < b else b


@numba.njit(cache=True, nogil=True)
def _answer(hi, lo, start: int, stop: int, length: int, k: int, peak: float, has_nan: bool) -> float:
    """``peak`` raised to the largest range of the windows of ``length`` samples starting at
    ``start..stop - 1`` of level-``k`` arrays ``hi``/``lo`` (NaN ranges ignored)."""
    shift = length - (1 << k)
    for i in range(start, stop):
        tie = _hi(hi[i], hi[i + shift], has_nan) - _lo(lo[i], lo[i + shift], has_nan)
        if has_nan:
            if tie == tie and not (peak >= tie):
                peak = tie
        elif tie > peak:
            peak = tie
    return peak


@numba.njit(cache=True, nogil=True)
def _next_level(hi, lo, stop: int, k: int, has_nan: bool) -> None:
    """Level ``k + 1`` from level ``k`` in place at positions ``0..stop - 1`` (ascending: each position
    reads ``i + 2**k`` before it is overwritten)."""
    half = 1 << k
    for i in range(stop):
        hi[i] = _hi(hi[i], hi[i + half], has_nan)
        lo[i] = _lo(lo[i], lo[i + half], has_nan)


@numba.njit(cache=True, nogil=True)
def mtie_blocked(x: np.ndarray, window: np.ndarray, order: np.ndarray, has_nan: bool, block: int,
                 top: int) -> np.ndarray:
    """MTIE (k,) for windows of ``window`` (k,) samples (each ``<= x.size``), visited in increasing
    ``order``; levels ``0..top`` in blocks of ``block`` start positions (module docstring)."""
    n = x.size
    out = np.full(window.size, np.nan)
    start_peak = np.nan if has_nan else -np.inf
    peaks = np.full(window.size, start_peak)
    while top > 0 and (1 << top) > n:
        top -= 1
    reach = 1 << (top + 1)
    hi = x.copy()
    lo = x.copy()
    # Phase 1: windows shorter than 2**(top + 1), block by block; level `top` written back.
    buf_hi = np.empty(block + reach)
    buf_lo = np.empty(block + reach)
    for s in range(0, n, block):
        size = min(block + reach, n - s)
        buf_hi[:size] = hi[s : s + size]
        buf_lo[:size] = lo[s : s + size]
        k = 0
        for idx in range(order.size):
            j = order[idx]
            length = window[j]
            if length >= reach:
                break
            while (1 << (k + 1)) <= length:
                _next_level(buf_hi, buf_lo, size - (2 << k) + 1, k, has_nan)
                k += 1
            stop = min(block, n - length + 1 - s)  # windows of this block that fit in the record
            if stop > 0:
                peaks[j] = _answer(buf_hi, buf_lo, 0, stop, length, k, peaks[j], has_nan)
        while k < top:
            _next_level(buf_hi, buf_lo, size - (2 << k) + 1, k, has_nan)
            k += 1
        keep = min(block, size)
        hi[s : s + keep] = buf_hi[:keep]
        lo[s : s + keep] = buf_lo[:keep]
    # Phase 2: the longer windows over the whole record, from level `top` upwards.
    k = top
    for idx in range(order.size):
        j = order[idx]
        length = window[j]
        if length < reach:
            continue
        while (1 << (k + 1)) <= length:
            _next_level(hi, lo, n - (2 << k) + 1, k, has_nan)
            k += 1
        peaks[j] = _answer(hi, lo, 0, n - length + 1, length, k, peaks[j], has_nan)
    for j in range(window.size):
        if not (has_nan and peaks[j] != peaks[j]):
            out[j] = peaks[j]
    return out
