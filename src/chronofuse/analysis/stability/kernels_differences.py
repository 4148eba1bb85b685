"""Primitives every raw stability kernel is built from: input checks and lagged phase differences.

One idea: the binomial difference of the phase at lag ``m`` (second, ``x[i+2m] - 2 x[i+m] + x[i]``,
for the Allan family; third, ``x[i+3m] - 3 x[i+2m] + 3 x[i+m] - x[i]``, for the Hadamard family,
NIST SP 1065 eqs. (7), (11), (18), (20)) and the sum of its squares over a phase record with missing
(NaN) samples, by one of two rules:

- ``"samples"``: a term is skipped only when one of its own samples (``x[i]``, ``x[i+m]``, ``x[i+2m]``
  (, ``x[i+3m]``)) is missing: allantools' gap-robust ADEV and Stable32 (1 % scattered gaps in 1e4
  points keep about 97 % of the terms at every m);
- ``"span"``: a term is skipped when any sample between its first and its last is missing. This is what
  "its own samples" means for phase integrated from frequency: a phase difference across a missing
  frequency sample is unknown, however far its end points are from the gap.

The Allan (:mod:`~chronofuse.analysis.stability.kernels_allan`), total and TIE kernels all start here.

The sums run in numba loops over contiguous slices with reassociated (vectorized) additions
(``difference_sum_of_squares_fused``, ``difference_sum_of_squares_span``); their readable numpy twin
(``difference_sum_of_squares``) is compared in the tests.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = [
    "SECOND",
    "THIRD",
    "REASSOC",
    "check_kernel_inputs",
    "lagged_difference",
    "sum_of_squares",
    "nan_prefix",
    "difference_sum_of_squares",
    "finite_sum",
    "contiguous_difference_sum",
    "difference_sum_of_squares_fused",
    "difference_sums_fused",
    "difference_sum_of_squares_span",
    "difference_sum_of_squares_samples",
    "term_validity",
    "SKIP_RULES",
]

#: The two rules for skipping the terms of a difference statistic on a record with gaps (module docstring).
SKIP_RULES = ("samples", "span")

# The two phase differences: second (Allan family, 3 samples) and third (Hadamard family, 4 samples).
SECOND = 2
THIRD = 3


def check_kernel_inputs(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Check the shapes and types every raw kernel expects; return ``(x, m, tau0_s)`` as float64/int64/float.

    ``x`` must be 1-D (N,), ``m`` 1-D (k,) of integers >= 1, ``tau0_s`` a positive number. Nothing is
    reshaped: a 2-D ``x`` or a scalar ``m`` is rejected.
    """
    x = np.asarray(x, dtype=np.float64)
    m_arr = np.asarray(m)
    if x.ndim != 1:
        raise ValueError(f"x.shape == {x.shape}, must be (N,)")
    if m_arr.ndim != 1:
        raise ValueError(f"m.shape == {m_arr.shape}, must be (k,)")
    if m_arr.size and not np.issubdtype(m_arr.dtype, np.integer):
        raise ValueError(f"m.dtype == {m_arr.dtype}, must be an integer type")
    m_arr = m_arr.astype(np.int64)
    if np.any(m_arr < 1):
        raise ValueError(f"m == {m_arr[m_arr < 1].tolist()}, must be >= 1")
    tau0_s = float(tau0_s)
    if not (np.isfinite(tau0_s) and tau0_s > 0):
        raise ValueError(f"tau0_s == {tau0_s}, must be > 0")
    return x, m_arr, tau0_s


def lagged_difference(x: np.ndarray, m: int, order: int, work: np.ndarray | None = None) -> np.ndarray:
    """Binomial difference of ``x`` (N,) at lag ``m``, shape (N - order m,).

    ``order == 2``: ``d[i] = x[i+2m] - 2 x[i+m] + x[i]``; ``order == 3``:
    ``d[i] = x[i+3m] - 3 x[i+2m] + 3 x[i+m] - x[i]``, evaluated left to right as written (the order
    Stable32 and allantools use). A NaN sample makes every term using it NaN. ``work``, if given, is
    scratch of shape (2, >= N - order m) reused across calls (no allocation per call); the result is a
    view of it.
    """
    length = x.size - order * m
    if length <= 0:
        return np.empty(0)
    if work is None:
        work = np.empty((2, length))
    d, t = work[0, :length], work[1, :length]
    if order == SECOND:
        np.multiply(x[m : m + length], 2.0, out=t)
        np.subtract(x[2 * m : 2 * m + length], t, out=d)
        np.add(d, x[:length], out=d)
        return d
    np.multiply(x[2 * m : 2 * m + length], 3.0, out=t)
    np.subtract(x[3 * m : 3 * m + length], t, out=d)
    np.multiply(x[m : m + length], 3.0, out=t)
    np.add(d, t, out=d)
    np.subtract(d, x[:length], out=d)
    return d


def sum_of_squares(d: np.ndarray) -> float:
    """``sum(d**2)`` of ``d`` (L,) with numpy's own single-threaded loop.

    Not ``np.dot``: OpenBLAS runs large dot products on several threads, which stall when other
    processes hold the cores (measured: 10x slower medians on a shared 2-core machine).
    """
    return float(np.einsum("i,i->", d, d))


def nan_prefix(x: np.ndarray) -> np.ndarray:
    """``c[i]`` = number of NaN in ``x[:i]``, shape (N + 1,): ``x[i : j]`` holds no NaN iff ``c[j] == c[i]``."""
    return np.concatenate(([0], np.cumsum(np.isnan(x), dtype=np.int64)))


def term_validity(x: np.ndarray, m: int, order: int, step: int, rule: str) -> np.ndarray:
    """Which terms of the lagged differences of ``order`` at lag ``m`` are kept, by ``rule``: a boolean
    array over the starts ``0, step, 2 step, ... < N - order m`` (shape (ceil((N - order m) / step),)).

    ``"samples"``: the term's own samples ``x[i + k m]`` (k = 0..order) are present; ``"span"``: no sample
    of ``x[i : i + order m + 1]`` is missing.
    """
    length = max(x.size - order * m, 0)
    # Strided slices, not gathers at starts + k m: the same elements, without the index arrays.
    if rule == "span":
        c = nan_prefix(x)
        return c[order * m + 1: order * m + 1 + length: step] == c[:length:step]
    if rule != "samples":
        raise ValueError(f"rule == {rule!r}, must be one of {list(SKIP_RULES)}")
    present = ~np.isnan(x)
    keep = present[:length:step].copy()
    for k in range(1, order + 1):
        keep &= present[k * m: k * m + length: step]
    return keep


def difference_sum_of_squares(x: np.ndarray, m: int, order: int, step: int = 1,
                              rule: str = "span") -> tuple[float, int]:
    """Readable twin of the fused sums: sum of squares of the lagged differences of ``order`` of ``x`` (N,)
    at lag ``m``, starts ``0, step, 2 step, ...``, skipping the terms ``rule`` skips (see
    :func:`term_validity`); and their count."""
    d = lagged_difference(x, m, order).copy()[::step]
    if np.isnan(x).any():
        d = d[term_validity(x, m, order, step, rule)]
    return sum_of_squares(d), int(d.size)


# Reassociation only (no "nnan": a NaN sum still tells a gap): with the terms read from slices the sum
# vectorizes, 5x faster than the strict left-to-right sum on one core.
REASSOC = {"reassoc"}


@numba.njit(cache=True, nogil=True, fastmath=REASSOC)
def finite_sum(x: np.ndarray) -> float:
    """``np.add.reduce(x)`` with reassociated (vectorized) additions: finite iff ``x`` holds no NaN or
    infinity (or its sum overflows); the stability engine's one pass over a record to vouch for it."""
    total = 0.0
    for i in range(x.size):
        total += x[i]
    return total


@numba.njit(cache=True, nogil=True, fastmath=REASSOC)
def contiguous_difference_sum(x: np.ndarray, lag: int, order: int) -> tuple[float, int]:
    """Sum of squares of the lag-``lag`` differences of ``order`` of ``x`` (read through slices)."""
    count = max(x.size - order * lag, 0)
    total = 0.0
    if order == 2:
        a, b, c = x[2 * lag : 2 * lag + count], x[lag : lag + count], x[:count]
        for i in range(count):
            d = a[i] - 2.0 * b[i] + c[i]
            total += d * d
    else:
        a, b, c, e = x[3 * lag : 3 * lag + count], x[2 * lag : 2 * lag + count], x[lag : lag + count], x[:count]
        for i in range(count):
            d = a[i] - 3.0 * b[i] + 3.0 * c[i] - e[i]
            total += d * d
    return total, count


@numba.njit(cache=True, nogil=True, fastmath=REASSOC)
def difference_sum_of_squares_fused(x: np.ndarray, m: int, order: int, step: int) -> tuple[float, int]:
    """The numba twin of :func:`difference_sum_of_squares`: one pass, no temporaries.

    Terms start at ``i = 0, step, 2 step, ...`` (``step = 1``: overlapping; ``step = m``: the phase
    decimated by ``m``). Returns ``(sum of squares, count)``, or ``(nan, -1)`` when a term is NaN (a
    record with gaps goes to :func:`difference_sum_of_squares_span`, which applies the span rule).
    """
    if step == 1:
        total, count = contiguous_difference_sum(x, m, order)  # contiguous slices: the loop vectorizes
    else:
        total, count = contiguous_difference_sum(np.ascontiguousarray(x[::step]), 1, order)
    if total == total:
        return total, count
    return np.nan, -1


@numba.njit(cache=True, nogil=True)
def difference_sums_fused(x: np.ndarray, m: np.ndarray, order: int, overlapping: bool) -> tuple[np.ndarray, np.ndarray]:
    """:func:`difference_sum_of_squares_fused` at every factor of ``m`` (k,) in one call (step 1 when
    ``overlapping``, else ``m``): sums (k,) and counts (k,); a count of -1 marks a NaN term.

    Non-overlapping, each decimated phase ``x[::m]`` is taken from the last one whose factor divides
    ``m`` (``x[::4]`` from ``x[::2]``: on an octave grid each is read from an array half its size, not
    from the whole record); the values, and so the sums, are the same.
    """
    sums = np.empty(m.size)
    counts = np.empty(m.size, dtype=np.int64)
    source = x
    source_m = 1
    for j in range(m.size):
        if overlapping:
            sums[j], counts[j] = difference_sum_of_squares_fused(x, m[j], order, 1)
            continue
        if m[j] % source_m != 0:
            source = x
            source_m = 1
        decimated = np.ascontiguousarray(source[:: m[j] // source_m])  # x[::m[j]]
        total, count = contiguous_difference_sum(decimated, 1, order)
        sums[j], counts[j] = (total, count) if total == total else (np.nan, -1)
        source = decimated
        source_m = m[j]
    return sums, counts


@numba.njit(cache=True, nogil=True)
def difference_sum_of_squares_span(x: np.ndarray, c: np.ndarray, m: int, order: int, step: int) -> tuple[float, int]:
    """The fused sum on a record with gaps: terms whose span ``x[i : i + order m + 1]`` holds a missing
    sample (``c`` from :func:`nan_prefix`) are skipped."""
    last = max(x.size - order * m, 0)
    total = 0.0
    count = 0
    for i in range(0, last, step):
        if c[i + order * m + 1] != c[i]:
            continue
        if order == 2:
            d = x[i + 2 * m] - 2.0 * x[i + m] + x[i]
        else:
            d = x[i + 3 * m] - 3.0 * x[i + 2 * m] + 3.0 * x[i + m] - x[i]
        total += d * d
        count += 1
    return total, count


@numba.njit(cache=True, nogil=True)
def difference_sum_of_squares_samples(x: np.ndarray, m: int, order: int, step: int) -> tuple[float, int]:
    """The fused sum on a record with gaps by the ``"samples"`` rule: a term is skipped only when one of its
    own samples is missing (then the term itself is NaN, which is the test)."""
    last = max(x.size - order * m, 0)
    total = 0.0
    count = 0
    for i in range(0, last, step):
        if order == 2:
            d = x[i + 2 * m] - 2.0 * x[i + m] + x[i]
        else:
            d = x[i + 3 * m] - 3.0 * x[i + 2 * m] + 3.0 * x[i + m] - x[i]
        if d == d:
            total += d * d
            count += 1
    return total, count
