"""EDFs from SP 1065's approximation tables: simple ADEV (Table 5), TOTDEV (Table 7), the total family and
Theo1 (the Greenhall algorithm itself is :mod:`chronofuse.analysis.stability.edf`)."""

from __future__ import annotations

import numpy as np

from chronofuse.analysis.stability.edf import _check_alpha, _integer_rows, _result, greenhall_edf

# SP 1065 Table 7 (TOTVAR): (b, c) for alpha = 0, -1, -2.
_TOTDEV_TABLE7 = {0: (1.50, 0.0), -1: (1.17, 0.22), -2: (0.93, 0.36)}
_TOTDEV_TABLE7_ARRAY = np.array([_TOTDEV_TABLE7[a] for a in (0, -1, -2)])  # row -alpha



def simple_adev_edf(alpha, m, n_points: int):
    """Simple approximate ADEV EDF of SP 1065 Table 5 (after Howe, Allan and Barnes 1981), PM noises.

    White PM (alpha = 2): ``(N+1)(N-2m) / (2(N-m))``; flicker PM (alpha = 1):
    ``exp(sqrt(ln((N-1)/(2m)) ln((2m+1)(N-1)/4)))``, ``N`` phase points. ``alpha`` and ``m`` scalars or
    (k,) arrays; a float for scalars, else an array (k,).
    """
    alpha, m, scalar = _integer_rows(alpha, m)
    _check_alpha(alpha, (2, 1))
    N = float(n_points)
    mf = m.astype(float)
    with np.errstate(invalid="ignore"):
        flicker = np.exp(np.sqrt(np.log((N - 1.0) / (2.0 * mf)) * np.log((2.0 * mf + 1.0) * (N - 1.0) / 4.0)))
    white = (N + 1.0) * (N - 2.0 * mf) / (2.0 * (N - mf))
    return _result(np.where(alpha == 2, white, flicker), scalar)


def totdev_edf(alpha, m, n_points: int):
    """TOTDEV EDF: SP 1065 Table 7, ``b N/m - c`` (alpha 0, -1, -2); SP 1065 Table 5 for PM noise (2, 1).

    ``alpha`` and ``m`` scalars or (k,) arrays; a float for scalars, else an array (k,).
    """
    alpha, m, scalar = _integer_rows(alpha, m)
    _check_alpha(alpha, (2, 1, 0, -1, -2))
    pm = alpha > 0
    b, c = _TOTDEV_TABLE7_ARRAY[np.clip(-alpha, 0, 2)].T  # PM rows are replaced below
    edf = b * n_points / m - c
    if pm.any():
        edf[pm] = simple_adev_edf(alpha[pm], m[pm], n_points)
    return _result(edf, scalar)


def mtotdev_edf(alpha, m, n_points: int):
    """MTOTDEV/TTOTDEV EDF: Greenhall's MDEV EDF (what Stable32 uses, see the module docstring)."""
    return greenhall_edf(alpha, 2, m, n_points, overlapping=True, modified=True)


def htotdev_edf(alpha, m, n_points: int):
    """HTOTDEV EDF: Greenhall's OHDEV EDF (a lower bound; SP 1065 has no HTOTDEV EDF)."""
    return greenhall_edf(alpha, 3, m, n_points, overlapping=True, modified=False)


def theo1_edf(alpha, m, n_points: int):
    """Theo1 EDF, SP 1065 Theo1 section (Howe & Tasset 2004), ``r = 0.75 m``, ``N`` phase points.

    ``alpha`` (-2..2) and ``m`` scalars or (k,) arrays; a float for scalars, else an array (k,).
    """
    alpha, m, scalar = _integer_rows(alpha, m)
    _check_alpha(alpha, (2, 1, 0, -1, -2))
    N = float(n_points)
    r = 0.75 * m
    by_alpha = {
        2: lambda r: 0.86 * (N + 1.0) * (N - 4.0 * r / 3.0) / (N - r) * r / (r + 1.14),
        1: lambda r: (4.798 * N**2 - 6.374 * N * r + 12.387 * r) / (np.sqrt(r + 36.6) * (N - r) * (N + 0.3))
        * r / (r + 0.3),
        0: lambda r: ((4.1 * N + 0.8) / r - (3.1 * N + 6.5) / N) * r**1.5 / (r**1.5 + 5.2),
        -1: lambda r: (2.0 * N**2 - 1.3 * N * r - 3.5 * r) / (N * r) * r**3 / (r**3 + 2.3),
        -2: lambda r: (4.4 * N - 2.0) / (2.9 * r) * ((4.4 * N - 1.0) ** 2 - 8.6 * r * (4.4 * N - 1.0) + 11.4 * r**2)
        / (4.4 * N - 3.0) ** 2,
    }
    edf = np.empty(m.size)
    for a, formula in by_alpha.items():
        rows = alpha == a
        if rows.any():
            edf[rows] = formula(r[rows])
    return _result(edf, scalar)


__all__ = ["simple_adev_edf", "totdev_edf", "mtotdev_edf", "htotdev_edf", "theo1_edf"]
