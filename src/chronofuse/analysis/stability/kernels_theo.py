"""Raw Theo1 kernel (engine signature ``theo1_raw(x, m, tau0_s) -> (dev, n)``).

Theo1 (D. A. Howe and T. K. Peppar; as given in NIST SP 1065 (2008), eq. (30) in allantools' citation):

``Theo1(m, tau0, N) = 1 / (0.75 (N - m) (m tau0)^2) * sum_{i=1}^{N-m} sum_{delta=0}^{m/2-1}
1 / (m/2 - delta) * [(x_i - x_{i-delta+m/2}) + (x_{i+m} - x_{i+delta+m/2})]^2``

for even averaging factors ``2 <= m <= N - 1``; its averaging time is ``tau = 0.75 m tau0``. No bias
correction here (``stability.bias`` applies Stable32's). ``n`` is allantools' count of terms,
``(N - m) m / 2``.

``x``: gap-free phase in seconds (N,); ``m``: int64 (k,), even, within ``2..max_m_theo1(N)``. The numba
kernel runs the inner sum over ``i`` for each ``delta`` (contiguous, vectorised loads; ``delta`` in
parallel): O((N - m) m / 2) per factor, every term O(1). ``theo1_numpy`` is its readable twin.
"""

from __future__ import annotations

import numba
import numpy as np

from chronofuse.analysis.stability.kernels_total import check_total_inputs

__all__ = ["theo1_raw", "theo1_numpy", "max_m_theo1", "THEO1_TAU_FACTOR"]

# Theo1's averaging time is 0.75 m tau0 (SP 1065).
THEO1_TAU_FACTOR = 0.75

_FASTMATH = {"reassoc", "contract", "nsz", "arcp"}


def max_m_theo1(n_points: int) -> int:
    """Largest (even) Theo1 averaging factor for N phase points: the largest even m <= N - 1."""
    top = int(n_points) - 1
    return max(0, top - top % 2) if top >= 2 else 0


def _check_theo1(x, m, tau0_s):
    x, m, tau0_s = check_total_inputs(x, m, tau0_s, max_m_theo1(np.size(x)), "theo1")
    if np.any(m % 2):
        raise ValueError(f"m == {m[m % 2 == 1].tolist()}, must be even for theo1")
    return x, m, tau0_s


@numba.njit(cache=True, fastmath=_FASTMATH)
def _theo1_inner(x: np.ndarray, m: int, d: int) -> float:
    """``sum_i (x_i - x_{i+h-d} + x_{i+m} - x_{i+h+d})^2 / (h - d)`` over 0-based i < N - m, h = m/2."""
    h = m // 2
    # Shifted views indexed by the bare loop counter: contiguous vector loads, no wraparound checks.
    x_lo, x_m, x_hi = x[h - d :], x[m:], x[h + d :]
    acc = 0.0
    for i in range(x.size - m):
        t = x[i] - x_lo[i] + x_m[i] - x_hi[i]
        acc += t * t
    return acc / (h - d)


@numba.njit(cache=True, parallel=True)
def _theo1_parallel(x: np.ndarray, m: int) -> np.ndarray:
    partial = np.zeros(m // 2)
    for d in numba.prange(m // 2):
        partial[d] = _theo1_inner(x, m, d)
    return partial


@numba.njit(cache=True)
def _theo1_serial(x: np.ndarray, m: int) -> np.ndarray:
    partial = np.zeros(m // 2)
    for d in range(m // 2):
        partial[d] = _theo1_inner(x, m, d)
    return partial


# Below this many terms a parallel region costs more than it saves (and much more on a loaded machine).
_PARALLEL_MIN_TERMS = 4_000_000


def _theo1_sum(x: np.ndarray, m: int) -> float:
    """The double sum of eq. (30) for one even m: O((N - m) m / 2), over delta in parallel when large."""
    driver = _theo1_parallel if (x.size - m) * (m // 2) >= _PARALLEL_MIN_TERMS else _theo1_serial
    return float(np.sum(driver(x, m)))


def theo1_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Theo1 deviation (no bias correction), SP 1065 eq. (30); tau = 0.75 m tau0.

    ``x`` (N,) phase in s, ``m`` (k,) even in ``2..max_m_theo1(N)``. Returns ``dev`` (k,) and
    ``n`` (k,) == (N - m) m / 2.
    """
    x, m, tau0_s = _check_theo1(x, m, tau0_s)
    if m.size == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    # Theo1 only sees phase differences: removing the mean keeps the sums well conditioned.
    xc = x - np.mean(x)
    dev = np.empty(m.size)
    for k, mk in enumerate(m):
        total = _theo1_sum(xc, int(mk))
        dev[k] = np.sqrt(total / (THEO1_TAU_FACTOR * (x.size - mk) * (mk * tau0_s) ** 2))
    return dev, ((x.size - m) * (m // 2)).astype(np.int64)


def theo1_numpy(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Numpy twin of :func:`theo1_raw`, written from eq. (30) with its 1-based indices."""
    x, m, tau0_s = _check_theo1(x, m, tau0_s)
    n_points = x.size
    dev = np.empty(m.size)
    for k, mk in enumerate(m):
        half = mk // 2
        i = np.arange(1, n_points - mk + 1)  # i = 1 .. N - m
        total = 0.0
        for delta in range(half):
            bracket = (x[i - 1] - x[i - delta + half - 1]) + (x[i + mk - 1] - x[i + delta + half - 1])
            total += np.sum(bracket**2) / (half - delta)
        dev[k] = np.sqrt(total / (0.75 * (n_points - mk) * (mk * tau0_s) ** 2))
    return dev, ((n_points - m) * (m // 2)).astype(np.int64)
