"""Time columns in numba: decimal text to exact integer nanoseconds, and the regular grid of the tags.

Both are sequential passes over 1e7-1e8 values that numpy can only do in many array passes with big
temporaries (the string ops of :func:`chronofuse.io.columns.decimal_text_to_ns` took 23 s and 2 GB for 1e7
tags); each kernel here sits beside its readable numpy twin, which the tests compare:

- :func:`parse_decimal_ns` reads the UTF-8 bytes of a pyarrow string array (its data and offsets
  buffers) directly: ``[+-]digits[.digits]`` with white space around, the integer and fraction parts
  apart, ``ns = whole * ns_per_unit + round(fraction_17_digits * p / q)`` exactly (``p/q = ns_per_unit /
  1e17``), as :func:`~chronofuse.io.columns.decimal_text_to_ns` (its twin). Text it does not take (an
  exponent, anything else) is reported by index, and the caller takes the twin's exact path for it.
- :func:`grid_pass` does the work of :func:`chronofuse.io.records._time_grid_numpy` (the twin) after the
  median step: the whole number of intervals of every step (the first that is not, by index), the slot of
  every tag (their running sum), and the least-squares sums of offset against slot; :func:`residual_pass`
  the rms and largest distance of the tags from their slots.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["parse_decimal_ns", "grid_pass", "centred_slope", "residual_pass", "grid_epochs", "FRACTION_DIGITS"]

FRACTION_DIGITS = 17


@numba.njit(cache=True, nogil=True)
def parse_decimal_ns(data: np.ndarray, offsets: np.ndarray, start: int, count: int, per_unit: int, p: int, q: int,
                     out: np.ndarray) -> int:
    """Parse strings ``start .. start + count - 1`` of a string array (``data`` uint8, ``offsets`` int32 or
    int64, ``count + 1`` of them from ``start``) into ``out`` (count,) int64 ns; returns the index of the first
    string it cannot take (-1 if none). ``whole`` beyond ``(2**63 - 1) // per_unit`` is not taken either."""
    limit = (np.int64(9223372036854775807) // per_unit) - 1
    for k in range(count):
        i = offsets[start + k]
        end = offsets[start + k + 1]
        while i < end and (data[i] == 32 or data[i] == 9 or data[i] == 13):
            i += 1
        while end > i and (data[end - 1] == 32 or data[end - 1] == 9 or data[end - 1] == 13):
            end -= 1
        negative = False
        if i < end and (data[i] == 43 or data[i] == 45):
            negative = data[i] == 45
            i += 1
        whole = np.int64(0)
        digits = 0
        while i < end and 48 <= data[i] <= 57:
            if whole > limit:
                return k
            whole = whole * 10 + (np.int64(data[i]) - 48)
            digits += 1
            i += 1
        frac = np.int64(0)
        frac_digits = 0
        if i < end and data[i] == 46:
            i += 1
            while i < end and 48 <= data[i] <= 57:
                if frac_digits < FRACTION_DIGITS:
                    frac = frac * 10 + (np.int64(data[i]) - 48)
                    frac_digits += 1
                digits += 1
                i += 1
        if i != end or digits == 0 or whole > limit:
            return k
        for _ in range(FRACTION_DIGITS - frac_digits):
            frac *= 10
        ns = whole * per_unit + (frac * p + q // 2) // q
        out[k] = -ns if negative else ns
    return -1


@numba.njit(cache=True, nogil=True)
def grid_pass(t_ns: np.ndarray, interval_ns: float, tolerance: float, slots: np.ndarray) -> tuple[int, np.ndarray]:
    """Slots (into ``slots``, (N,) int64, ``slots[0] = 0``) of time tags ``t_ns`` (N,) on a grid of
    ``interval_ns``: each step rounds to a whole number of intervals, which must be >= 1 and within
    ``tolerance`` of the step. Returns ``(k, sums)``: ``k`` the index of the first bad step (its second
    tag), -1 if none; ``sums`` = ``[sum s, sum o, sum s*s, sum s*o]`` over slot ``s`` and offset
    ``o = t - t[0]`` (float64), for the least-squares interval."""
    sums = np.zeros(4)
    slots[0] = 0
    t0 = t_ns[0]
    for k in range(1, t_ns.size):
        step = t_ns[k] - t_ns[k - 1]
        ratio = step / interval_ns
        count = np.int64(np.rint(ratio))
        if count < 1 or abs(ratio - count) > tolerance:
            return k, sums
        s = slots[k - 1] + count
        slots[k] = s
        o = float(t_ns[k] - t0)
        sums[0] += s
        sums[1] += o
        sums[2] += float(s) * float(s)
        sums[3] += float(s) * o
    return -1, sums


@numba.njit(cache=True, nogil=True)
def residual_pass(t_ns: np.ndarray, slots: np.ndarray, interval_ns: float) -> tuple[float, float, float]:
    """``(start, rms, max)`` in ns of the residuals ``o - s * interval`` (``o = t - t[0]``): ``start`` their
    mean (the grid's phase against the first tag), then the rms and largest distance from it."""
    t0 = t_ns[0]
    total = 0.0
    for k in range(t_ns.size):
        total += float(t_ns[k] - t0) - slots[k] * interval_ns
    start = total / t_ns.size
    square = 0.0
    peak = 0.0
    for k in range(t_ns.size):
        r = float(t_ns[k] - t0) - slots[k] * interval_ns - start
        square += r * r
        if abs(r) > peak:
            peak = abs(r)
    return start, np.sqrt(square / t_ns.size), peak


@numba.njit(cache=True, nogil=True)
def centred_slope(t_ns: np.ndarray, slots: np.ndarray, slot_mean: float, offset_mean: float) -> float:
    """Least-squares slope of offset ``o = t - t[0]`` against slot, from centred sums (as the twin)."""
    t0 = t_ns[0]
    sxy = 0.0
    sxx = 0.0
    for k in range(t_ns.size):
        ds = slots[k] - slot_mean
        sxy += ds * (float(t_ns[k] - t0) - offset_mean)
        sxx += ds * ds
    return sxy / sxx


@numba.njit(cache=True, nogil=True)
def grid_epochs(t0: np.int64, start: float, interval: float, n: int) -> np.ndarray:
    """``t0 + rint(start + k interval)`` for ``k < n``: the epoch of every grid slot, int64 ns (n,)."""
    out = np.empty(n, dtype=np.int64)
    for k in range(n):
        out[k] = t0 + np.int64(np.rint(start + k * interval))
    return out
