"""Bias corrections of the total deviations, as Stable32 applies them.

Each function returns the factor the raw deviation is MULTIPLIED by (``dev = factor * dev_raw``), of
shape (k,), from the identified noise ``alpha`` (k,) and averaging factors ``m`` (k,).

- TOTDEV: NIST SP 1065 (W. J. Riley, 2008), section on the total variance:
  ``E[TOTVAR] = AVAR (1 - a tau/T)`` with ``a = 0`` (white FM and the PM noises), ``1/(3 ln 2) =
  0.481`` (flicker FM), ``3/4`` (random-walk FM) and ``T = (N - 1) tau0`` the record length; the
  corrected deviation is ``dev_raw / sqrt(1 - a tau/T)``. Confirmed on Stable32's ocxo table (rows
  m = 256, 512, 1024: corrections of 0.3-1.2 % reproduced within 1e-3).
- HTOTDEV: SP 1065, section on the Hadamard total variance (its bias table):
  ``E[HTOTVAR] / HVAR = 1 + a`` with ``a = -0.005`` (white FM), ``-0.149`` (flicker FM), ``-0.229``
  (random-walk FM), 0 for the PM noises; corrected deviation ``dev_raw / sqrt(1 + a)``. Stable32's
  PHASE.DAT table, with and without correction, confirms the white-FM value (ratio 1.0025 at every
  m > 1). At ``m = 1`` HTOTDEV is the overlapping HDEV and is not corrected (Stable32 prints the same
  value in both tables).
- MTOTDEV, TTOTDEV: no correction. Stable32 prints the same MTOTDEV for PHASE.DAT whether it
  identified alpha = 1 or fixed alpha = 0 (rows m = 128, 256), and equal to the raw MTOTDEV at every
  row: Stable32 applies none.
- Theo1: no correction here (Theo1 is reported as is; SP 1065's TheoBR/TheoH rescaling is a
  different statistic).
"""

from __future__ import annotations

import numpy as np

__all__ = ["totdev_bias", "htotdev_bias", "TOTDEV_A", "HTOTDEV_A"]

# SP 1065 (total variance): a(alpha) of the TOTVAR bias 1 - a tau/T.
TOTDEV_A = {2: 0.0, 1: 0.0, 0: 0.0, -1: 1.0 / (3.0 * np.log(2.0)), -2: 0.75}
# SP 1065 (Hadamard total variance): a(alpha) of the HTOTVAR bias 1 + a.
HTOTDEV_A = {2: 0.0, 1: 0.0, 0: -0.005, -1: -0.149, -2: -0.229}


def totdev_bias(alpha: np.ndarray, m: np.ndarray, n_points: int) -> np.ndarray:
    """TOTDEV correction factor ``1 / sqrt(1 - a(alpha) m / (N - 1))`` (SP 1065, total variance).

    ``alpha``, ``m`` of shape (k,); ``n_points`` = N phase samples, so ``tau/T = m / (N - 1)``.
    """
    a = np.array([TOTDEV_A[int(al)] for al in np.asarray(alpha)], dtype=float)
    ratio = np.asarray(m, dtype=float) / (n_points - 1)
    return 1.0 / np.sqrt(1.0 - a * ratio)


def htotdev_bias(alpha: np.ndarray, m: np.ndarray, n_points: int) -> np.ndarray:
    """HTOTDEV correction factor ``1 / sqrt(1 + a(alpha))`` for ``m > 1``, 1 at ``m = 1``.

    SP 1065, Hadamard total variance; ``alpha``, ``m`` of shape (k,); ``n_points`` unused (the factor
    does not depend on the record length) but kept for the engine's common bias signature.
    """
    a = np.array([HTOTDEV_A[int(al)] for al in np.asarray(alpha)], dtype=float)
    factor = 1.0 / np.sqrt(1.0 + a)
    return np.where(np.asarray(m) > 1, factor, 1.0)
