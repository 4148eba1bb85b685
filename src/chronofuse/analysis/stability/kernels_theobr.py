"""TheoBR (bias-removed Theo1) and the TheoH hybrid of AVAR and TheoBR.

TheoBR (D. A. Howe, "TheoH: a hybrid, high-confidence statistic that improves on the Allan deviation",
Metrologia 43 (2006) S322; NIST SP 1065 (2008), TheoBR and TheoH sections):

``TheoBR(m) = [1/(n+1) sum_{i=0}^{n} AVAR(m = 9 + 3i) / Theo1(m = 12 + 4i)] Theo1(m)``,
``n = floor(0.1 N / 3 - 3)``,

the average ratio of the overlapping Allan variance to Theo1 at the same averaging time (``0.75 (12 +
4i) = 9 + 3i``) over the short taus where AVAR is well estimated, applied to Theo1 at every m (even,
``tau = 0.75 m tau0``). It removes Theo1's noise-dependent bias without identifying the noise. TheoH is
AVAR below ``k = 10 %`` of the record length and TheoBR from ``k`` on (``TheoH = AVAR(m)`` for
``m tau0 < k``, ``TheoBR(m)`` for ``0.75 m tau0 >= k``). The same definition (n, the 10 % split) is
implemented independently in the public Haskell library ``tau-sigma`` (``TauSigma.Statistics.Theo1``),
which was read to confirm the sum's range, not copied.

The bias ratio needs Theo1 at ``m = 12, 16, ..., 12 + 4n``: O(N**3 / 900) operations in all, about a
second at N = 1e4 on one core; :func:`theobr_numpy` is the readable twin (numpy Theo1, the ratio by the
definition), compared in the tests.
"""

from __future__ import annotations

import numpy as np

from chronofuse.analysis.stability.kernels_allan import oadev_raw
from chronofuse.analysis.stability.kernels_theo import _check_theo1, _theo1_sum, max_m_theo1, theo1_numpy, theo1_raw

__all__ = ["theobr_raw", "theobr_numpy", "theobr_ratio", "max_m_theobr", "theoh_split_s", "MIN_POINTS_THEOBR"]

#: ``n = floor(0.1 N / 3 - 3) >= 0`` needs 90 phase points.
MIN_POINTS_THEOBR = 90


def _n_terms(n_points: int) -> int:
    return int(np.floor(0.1 * n_points / 3.0 - 3.0))


def max_m_theobr(n_points: int) -> int:
    """Largest (even) TheoBR factor: Theo1's, for records of at least :data:`MIN_POINTS_THEOBR` points."""
    return max_m_theo1(n_points) if n_points >= MIN_POINTS_THEOBR else 0


def theoh_split_s(n_points: int, tau0_s: float) -> float:
    """TheoH's ``k``: 10 % of the record, ``floor(N / 10) tau0``; AVAR below it, TheoBR from it on."""
    return (int(n_points) // 10) * tau0_s


def theobr_ratio(x: np.ndarray) -> float:
    """``1/(n+1) sum_{i=0}^{n} AVAR(9 + 3i) / Theo1(12 + 4i)`` (both at tau0 = 1; the ratio does not
    depend on it) of a gap-free phase record ``x`` (N,)."""
    n = _n_terms(x.size)
    if n < 0:
        raise ValueError(f"x has {x.size} samples, TheoBR needs at least {MIN_POINTS_THEOBR}")
    i = np.arange(n + 1)
    avar = oadev_raw(x, (9 + 3 * i).astype(np.int64), 1.0)[0] ** 2
    xc = x - np.mean(x)
    theo1 = np.array([_theo1_sum(xc, int(m)) / (0.75 * (x.size - m) * m * m) for m in (12 + 4 * i)])
    return float(np.mean(avar / theo1))


def theobr_raw(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """TheoBR deviation at even factors ``m`` (k,), ``tau = 0.75 m tau0``; ``n`` as Theo1's."""
    x, m, tau0_s = _check_theo1(x, m, tau0_s)
    if x.size < MIN_POINTS_THEOBR:
        raise ValueError(f"x has {x.size} samples, TheoBR needs at least {MIN_POINTS_THEOBR}")
    dev, n = theo1_raw(x, m, tau0_s)
    return dev * np.sqrt(theobr_ratio(x)), n


def theobr_numpy(x: np.ndarray, m: np.ndarray, tau0_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Readable twin of :func:`theobr_raw`: the definition with numpy Theo1 and the overlapping AVAR."""
    x, m, tau0_s = _check_theo1(x, m, tau0_s)
    n = _n_terms(x.size)
    ratios = []
    for i in range(n + 1):
        avar = float(np.mean((x[2 * (9 + 3 * i):] - 2 * x[9 + 3 * i : -(9 + 3 * i)] + x[: -2 * (9 + 3 * i)]) ** 2)
                     / (2.0 * (9 + 3 * i) ** 2))
        theo1 = float(theo1_numpy(x, np.array([12 + 4 * i]), 1.0)[0][0]) ** 2
        ratios.append(avar / theo1)
    dev, count = theo1_numpy(x, m, tau0_s)
    return dev * np.sqrt(np.mean(ratios)), count
