"""The fixed-interval Rauch–Tung–Striebel smoother over a batch of filter results (the GNSSDO paper's eq. (3-7)).

H. E. Rauch, F. Tung and C. T. Striebel, "Maximum likelihood estimates of linear dynamic systems", AIAA
Journal 3(8), 1965. With the filter's posteriors ``x(k), P(k)`` and the next step's priors
``x-(k+1) = F x(k)``, ``P-(k+1) = F P(k) F' + Q``, backwards from the last epoch (``xs(T-1) = x(T-1)``)::

    C(k)  = P(k) F' P-(k+1)^-1
    xs(k) = x(k) + C(k) (xs(k+1) - x-(k+1))
    Ps(k) = P(k) + C(k) (Ps(k+1) - P-(k+1)) C(k)'

This is the only smoother in the package; it runs on all trials at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from chronofuse.estimation.filter import FilterResult
from chronofuse.estimation.interface import FrozenResult


@dataclass(frozen=True)
class SmootherResult(FrozenResult):
    """Smoothed states ``x`` (trials, steps, n), covariances ``P`` (trials, steps, n, n) and the gains ``C``
    (trials, steps, n, n; the last epoch's is zero). Arrays read-only."""

    x: np.ndarray
    P: np.ndarray
    C: np.ndarray


def rts_smooth(result: FilterResult, F) -> SmootherResult:
    """Smooth a :class:`~chronofuse.estimation.filter.FilterResult` of a filter with transition ``F``.

    ``F`` is (n, n), or time-varying (trials, steps, n, n) with ``F[:, k]`` carrying epoch ``k - 1`` to ``k``
    (an extended or error-state filter's linearisations). ``result.P_prior[:, k + 1]`` must be
    ``F P(k) F' + Q`` (true for :class:`KalmanFilter` results, whose every epoch is predict then update).
    Epochs without a measurement are smoothed like any other.
    """
    F = np.asarray(F, dtype=np.float64)
    x_f, P_f = result.x, result.P
    trials, steps, n = x_f.shape
    if F.shape not in ((n, n), (trials, steps, n, n)):
        raise ValueError(f"F has shape {F.shape}, must be ({n}, {n}) or ({trials}, {steps}, {n}, {n})")
    varying = F.ndim == 4
    xs = np.empty_like(x_f)
    Ps = np.empty_like(P_f)
    C = np.zeros_like(P_f)
    xs[:, -1] = x_f[:, -1]
    Ps[:, -1] = P_f[:, -1]
    for k in range(steps - 2, -1, -1):
        P_pred = result.P_prior[:, k + 1]
        # C = P F' P-^-1, solved as (P- C' = F P) since P- and P are symmetric
        F_next = F[:, k + 1] if varying else F
        gain = np.swapaxes(np.linalg.solve(P_pred, F_next @ P_f[:, k]), -1, -2)
        xs[:, k] = x_f[:, k] + np.einsum("nij,nj->ni", gain, xs[:, k + 1] - result.x_prior[:, k + 1])
        Ps[:, k] = P_f[:, k] + gain @ (Ps[:, k + 1] - P_pred) @ np.swapaxes(gain, -1, -2)
        C[:, k] = gain
    return SmootherResult(x=xs, P=Ps, C=C)
