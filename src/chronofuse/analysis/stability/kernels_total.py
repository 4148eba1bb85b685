"""Raw kernels of the total-deviation family: TOTDEV, MTOTDEV, TTOTDEV, HTOTDEV.

Every kernel has the stability-engine signature ``name_raw(x, m, tau0_s) -> (dev, n)``:

- ``x``: phase in seconds, float64 of shape (N,), gap-free (the engine fills gaps first);
- ``m``: int64 averaging factors of shape (k,), each within ``1 <= m <= max_m_<name>(N)``;
- ``dev``: float64 (k,), the deviation WITHOUT bias correction;
- ``n``: int64 (k,), the number of terms (Stable32's ``#`` column).

Definitions (W. J. Riley, *Handbook of Frequency Stability Analysis*, NIST SP 1065 (2008)):

- TOTDEV, eq. (25): the overlapping Allan variance of the phase record extended by odd reflection
  at both ends to 3N - 4 points; N - 2 terms.
- MTOTDEV, eq. (27) (D. A. Howe and F. Vernotte, PTTI 1999): for each of the N - 3m + 1 subsequences of 3m phase points, remove the
  linear trend estimated from the means of its first and last halves, extend it by even (uninverted)
  reflection to 9m points, and average the 6m squared second differences of its m-point means.
- TTOTDEV, eq. (28): ``tau / sqrt(3) * MTOTDEV`` with ``tau = m tau0``.
- HTOTDEV (SP 1065's Hadamard total variance; D. A. Howe et al., "A total estimator of the
  Hadamard function used for GPS operations", PTTI 2000): the same construction on the N - 1 fractional-frequency values (third
  differences of phase means); at ``m == 1`` Stable32 and allantools report the overlapping Hadamard
  deviation instead ("for best consistency", Riley), and so does this module.

The MTOTDEV and HTOTDEV sums come from
:func:`~chronofuse.analysis.stability.kernels_reflected.reflected_sum_of_squares` (O(1) per term,
blocks of subsequences in parallel); each kernel here has a numpy twin written straight from the
definition (``*_numpy``), which the tests compare against.

Equation numbers are those allantools cites for SP 1065. The averaging-factor limits match Stable32
and allantools: TOTDEV to T/2 (``(N - 1) // 2``, as Stable32's tables end), MTOTDEV/TTOTDEV to N/3 with at least two terms, HTOTDEV to (N - 1)/3 frequency points
with at least two terms (allantools' ``maximum_m`` and ``remove_small_ns``).
"""

from __future__ import annotations

import numpy as np

from chronofuse.analysis.stability.kernels_differences import check_kernel_inputs, contiguous_difference_sum, sum_of_squares
from chronofuse.analysis.stability.kernels_reflected import reflected_sum_of_squares

__all__ = [
    "totdev_raw",
    "mtotdev_raw",
    "ttotdev_raw",
    "htotdev_raw",
    "max_m_totdev",
    "max_m_mtotdev",
    "max_m_ttotdev",
    "max_m_htotdev",
    "totdev_numpy",
    "mtotdev_numpy",
    "ttotdev_numpy",
    "htotdev_numpy",
]


def check_total_inputs(x, m, tau0_s, max_m: int, name: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Check a raw kernel's inputs; return ``(x, m, tau0_s)`` as float64 (N,), int64 (k,), float.

    Nothing is reshaped: ``x`` must be 1-D and finite (these kernels take gap-free phase), ``m`` 1-D
    integers within ``1 <= m <= max_m``, ``tau0_s > 0``.
    """
    x, m_arr, tau0_s = check_kernel_inputs(x, m, tau0_s)
    if not np.all(np.isfinite(x)):
        raise ValueError(f"x contains NaN or Inf; {name} needs gap-free phase (fill gaps first)")
    too_large = m_arr > max_m
    if too_large.any():
        raise ValueError(f"m == {m_arr[too_large].tolist()}, must be within 1..{max_m} for {name} of {x.size} points")
    return x, m_arr, tau0_s


# --------------------------------------------------------------------------------------------------
# Averaging-factor limits
# --------------------------------------------------------------------------------------------------


def max_m_totdev(n_points: int) -> int:
    """Largest TOTDEV averaging factor for ``n_points`` phase points: T/2, i.e. ``(N - 1) // 2``."""
    return max(0, (int(n_points) - 1) // 2) if n_points >= 3 else 0


def max_m_mtotdev(n_points: int) -> int:
    """Largest MTOTDEV averaging factor: 3m <= N with at least two subsequences, ``(N - 1) // 3``."""
    return max(0, (int(n_points) - 1) // 3)


def max_m_ttotdev(n_points: int) -> int:
    """Largest TTOTDEV averaging factor (that of MTOTDEV)."""
    return max_m_mtotdev(n_points)


def max_m_htotdev(n_points: int) -> int:
    """Largest HTOTDEV averaging factor: 3m <= N - 1 frequency points with two subsequences, ``(N - 2) // 3``.

    Zero below 5 phase points (the m = 1 overlapping Hadamard deviation needs N - 3 >= 2 terms).
    """
    return max(0, (int(n_points) - 2) // 3) if n_points >= 5 else 0


# --------------------------------------------------------------------------------------------------
# TOTDEV (O(N) per factor in numpy: no sequential loop, so no numba)
# --------------------------------------------------------------------------------------------------


def _odd_reflection(x: np.ndarray) -> np.ndarray:
    """The (3N - 4,) record of NIST SP 1065 eq. (25): ``2 x_1 - x_{1+j}``, x, ``2 x_N - x_{N-j}``, j = 1..N-2."""
    head = 2.0 * x[0] - x[1:-1][::-1]
    tail = 2.0 * x[-1] - x[1:-1][::-1]
    return np.concatenate((head, x, tail))


def totdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Total deviation, NIST SP 1065 eq. (25), without bias correction.

    ``sigma^2(m tau0) = 1 / (2 (m tau0)^2 (N - 2)) * sum_{i=2}^{N-1} (x*_{i-m} - 2 x*_i + x*_{i+m})^2``
    over the odd-reflected record ``x*``. ``x`` (N,) phase in s, ``m`` (k,) in ``1..max_m_totdev(N)``;
    returns ``dev`` (k,) and ``n`` (k,) == N - 2.
    """
    x, m, tau0_s = check_total_inputs(x, m, tau0_s, max_m_totdev(np.size(x)), "totdev")
    n_points = x.size
    if m.size == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    xs = _odd_reflection(x)
    mid = n_points - 2  # index of x_1 (0-based x[0]) in xs
    # Centres x_2 .. x_{N-1} (1-based), i.e. xs[mid+1 : mid+N-1]: the lag-m second differences of the
    # slice that reaches m samples either side (contiguous, summed by the Allan kernels' fused loop).
    dev = np.empty(m.size)
    for k, mk in enumerate(m):
        mk = int(mk)
        s, _ = contiguous_difference_sum(xs[mid + 1 - mk : mid + n_points - 1 + mk], mk, 2)
        dev[k] = np.sqrt(s / (2.0 * (mk * tau0_s) ** 2 * (n_points - 2)))
    return dev, np.full(m.size, n_points - 2, dtype=np.int64)


def totdev_numpy(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """TOTDEV written term by term from SP 1065 eq. (25) with 1-based indices (reference twin)."""
    x, m, tau0_s = check_total_inputs(x, m, tau0_s, max_m_totdev(np.size(x)), "totdev")
    n_points = x.size

    def xstar(i: int) -> float:  # 1-based index into the reflected record
        if i < 1:
            return 2.0 * x[0] - x[1 - i]
        if i > n_points:
            return 2.0 * x[-1] - x[2 * n_points - i - 1]
        return x[i - 1]

    dev = np.empty(m.size)
    for k, mk in enumerate(m):
        terms = [(xstar(i - mk) - 2.0 * xstar(i) + xstar(i + mk)) ** 2 for i in range(2, n_points)]
        dev[k] = np.sqrt(np.sum(terms) / (2.0 * (mk * tau0_s) ** 2 * (n_points - 2)))
    return dev, np.full(m.size, n_points - 2, dtype=np.int64)


# --------------------------------------------------------------------------------------------------
# MTOTDEV, TTOTDEV
# --------------------------------------------------------------------------------------------------


def mtotdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Modified total deviation, NIST SP 1065 eq. (27), without bias correction.

    ``mod sigma^2_tot(m tau0) = 1 / (2 (m tau0)^2 (N - 3m + 1)) * sum_{n=1}^{N-3m+1}
    [1/(6m) sum_{i=n-3m}^{n+3m-1} (z#_i(m))^2]`` where ``z#_i(m)`` are the second differences of
    m-point means of the detrended, evenly reflected subsequence. ``x`` (N,) phase in s, ``m`` (k,)
    in ``1..max_m_mtotdev(N)``; returns ``dev`` (k,) and ``n`` (k,) == N - 3m + 1.
    """
    x, m, tau0_s = check_total_inputs(x, m, tau0_s, max_m_mtotdev(np.size(x)), "mtotdev")
    dev = np.empty(m.size)
    n = x.size - 3 * m + 1
    for k, mk in enumerate(m):
        total = reflected_sum_of_squares(x, int(mk), False)
        # 1/(2 (m tau0)^2 n) * 1/(6m) * (window sums / m)^2
        dev[k] = np.sqrt(total / (12.0 * float(mk) ** 5 * tau0_s**2 * n[k]))
    return dev, n.astype(np.int64)


def mtotdev_numpy(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Numpy twin of :func:`mtotdev_raw`, straight from SP 1065 eq. (27) (O(N m) per factor)."""
    x, m, tau0_s = check_total_inputs(x, m, tau0_s, max_m_mtotdev(np.size(x)), "mtotdev")
    n = x.size - 3 * m + 1
    dev = np.empty(m.size)
    for k, mk in enumerate(m):
        inner = [np.mean(_reflected_second_differences(x[i : i + 3 * mk], int(mk)) ** 2) for i in range(n[k])]
        dev[k] = np.sqrt(np.sum(inner) / (2.0 * (mk * tau0_s) ** 2 * n[k]))
    return dev, n.astype(np.int64)


def _reflected_second_differences(z: np.ndarray, m: int) -> np.ndarray:
    """The 6m second differences of m-point means of one subsequence ``z`` (3m,), SP 1065 sec. 5.2.12.

    Remove the linear trend from the means of the first and last halves, extend by uninverted even
    reflection to 9m points, take all 6m overlapping ``mean_1 - 2 mean_2 + mean_3``.
    """
    w = 3 * m
    h, hp = w // 2, w - w // 2
    slope = (z[hp:].mean() - z[:h].mean()) / hp  # the halves' centres are hp samples apart
    z = z - slope * np.arange(w)
    xstar = np.concatenate((z[::-1], z, z[::-1]))
    means = np.convolve(xstar, np.full(m, 1.0 / m), mode="valid")  # means[j] = mean(xstar[j:j+m])
    j = np.arange(6 * m)
    return means[j] - 2.0 * means[j + m] + means[j + 2 * m]


def ttotdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Time total deviation in seconds, NIST SP 1065 eq. (28): ``tau / sqrt(3) * MTOTDEV``, tau = m tau0.

    (allantools notes that SP 1065 prints tau^3 there; the variance scales by tau^2 / 3, as TDEV does.) Returns
    ``dev`` (k,) in s and ``n`` (k,) == N - 3m + 1.
    """
    dev, n = mtotdev_raw(x, m, tau0_s)
    return np.asarray(m) * tau0_s / np.sqrt(3.0) * dev, n


def ttotdev_numpy(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Numpy twin of :func:`ttotdev_raw`."""
    dev, n = mtotdev_numpy(x, m, tau0_s)
    return np.asarray(m) * tau0_s / np.sqrt(3.0) * dev, n


# --------------------------------------------------------------------------------------------------
# HTOTDEV
# --------------------------------------------------------------------------------------------------


def _overlapping_hadamard(x: np.ndarray, tau0_s: float) -> tuple[float, int]:
    """Overlapping Hadamard deviation at m = 1, NIST SP 1065 (overlapping Hadamard variance): N - 3 terms."""
    d = x[3:] - 3.0 * x[2:-1] + 3.0 * x[1:-2] - x[:-3]
    return float(np.sqrt(sum_of_squares(d) / (6.0 * d.size)) / tau0_s), d.size


def htotdev_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Hadamard total deviation, (SP 1065, Howe et al. PTTI 2000), without bias correction.

    On the N - 1 fractional frequencies ``y_i = (x_{i+1} - x_i) / tau0``: for each of the
    N - 3m subsequences of 3m values, remove the half-average linear trend (frequency drift),
    reflect evenly to 9m values and average the 6m squared second differences of m-point means;
    ``sigma^2 = 1 / (6 (N - 3m)) * sum (1/(6m) sum (...)^2)``. At m = 1 the overlapping Hadamard
    deviation is returned (Stable32, allantools). ``x`` (N,) phase in s; returns ``dev`` (k,) and
    ``n`` (k,) == N - 3m (N - 3 at m = 1).
    """
    x, m, tau0_s = check_total_inputs(x, m, tau0_s, max_m_htotdev(np.size(x)), "htotdev")
    # Window sums of y are phase differences / tau0: the phase itself is y's prefix sum.
    prefix = x / tau0_s
    dev = np.empty(m.size)
    n = np.empty(m.size, dtype=np.int64)
    for k, mk in enumerate(m):
        if mk == 1:
            dev[k], n[k] = _overlapping_hadamard(x, tau0_s)
            continue
        n[k] = x.size - 3 * mk
        total = reflected_sum_of_squares(prefix, int(mk), True)
        # 1/(6 n) * 1/(6m) * (window sums / m)^2
        dev[k] = np.sqrt(total / (36.0 * float(mk) ** 3 * n[k]))
    return dev, n


def htotdev_numpy(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Numpy twin of :func:`htotdev_raw`, built from the definition on the frequency record."""
    x, m, tau0_s = check_total_inputs(x, m, tau0_s, max_m_htotdev(np.size(x)), "htotdev")
    y = np.diff(x) / tau0_s
    dev = np.empty(m.size)
    n = np.empty(m.size, dtype=np.int64)
    for k, mk in enumerate(m):
        if mk == 1:
            dev[k], n[k] = _overlapping_hadamard(x, tau0_s)
            continue
        n[k] = y.size - 3 * mk + 1
        inner = [np.mean(_reflected_second_differences(y[i : i + 3 * mk], int(mk)) ** 2) for i in range(n[k])]
        dev[k] = np.sqrt(np.sum(inner) / (6.0 * n[k]))
    return dev, n
