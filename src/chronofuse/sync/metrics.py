"""Sync metrics (seed 001 eqs. 47-51): RMSE, convergence epochs, robustness, communication overhead."""

from __future__ import annotations

import numpy as np

from chronofuse.validation import check_array, check_scalar

__all__ = ["rmse_s", "running_rmse_s", "convergence_epochs", "robustness", "overhead"]


def rmse_s(error_s) -> float:
    """Eq. (47): ``sqrt(mean(err^2))`` over every trial and exchange (NaN = no estimate yet, left out)."""
    err = check_array(error_s, "error_s", ndim=2, allow_nan=True)
    return float(np.sqrt(np.nanmean(err**2)))


def running_rmse_s(error_s) -> np.ndarray:
    """``RMSE_k``: the RMSE over trials at each exchange ``k``, shape (steps,)."""
    err = check_array(error_s, "error_s", ndim=2, allow_nan=True)
    with np.errstate(invalid="ignore"):
        return np.sqrt(np.nanmean(err**2, axis=0))


def convergence_epochs(error_s, threshold_s: float, start: int = 0) -> int | None:
    """Eq. (48)/(50): ``K* = min{k >= start: RMSE_k <= tau}``, counted from ``start``; None if never."""
    check_scalar(threshold_s, "threshold_s", min_val=0.0, include_min=False)
    r = running_rmse_s(error_s)[int(start):]
    hit = np.flatnonzero(r <= threshold_s)
    return int(hit[0]) if hit.size else None


def robustness(error_nominal_s, error_stress_s, threshold_s: float, stress_end: int) -> dict:
    """Eqs. (49)-(50): ``delta_rmse_s = RMSE_stress - RMSE_nominal`` and the recovery epochs after the
    stress ends at exchange ``stress_end`` (None if the RMSE never returns below ``threshold_s``)."""
    return {"delta_rmse_s": rmse_s(error_stress_s) - rmse_s(error_nominal_s),
            "recovery_epochs": convergence_epochs(error_stress_s, threshold_s, start=stress_end)}


def overhead(interval_s: float, request_bits: int = 128, reply_bits: int = 256) -> dict:
    """Eq. (51): messages and bits per second of one link exchanging every ``interval_s``.

    A request carries a header and its slot number (default 128 bits); the reply also carries ``T_i``
    and ``T_B`` as two 64-bit timestamps (default 256 bits). Sizes are assumptions, not the seed's.
    """
    check_scalar(interval_s, "interval_s", min_val=0.0, include_min=False)
    rate = 1.0 / interval_s
    return {"messages_per_s": 2.0 * rate, "bits_per_s": (request_bits + reply_bits) * rate}
