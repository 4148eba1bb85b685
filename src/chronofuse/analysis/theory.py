"""Theoretical Allan variance of power-law oscillator noise and linear drift.

NIST SP 1065 (Riley 2008), Table 3 / section 5.2.10, with the measurement bandwidth ``f_h`` taken as
the Nyquist frequency ``rate_hz / 2`` of the sampled phase:

    white PM      h2:  3 f_h h2 / (4 pi^2 tau^2)
    flicker PM    h1:  (1.038 + 3 ln(2 pi f_h tau)) h1 / (4 pi^2 tau^2)   (valid for 2 pi f_h tau >> 1)
    white FM      h0:  h0 / (2 tau)
    flicker FM   hm1:  2 ln2 hm1
    random-walk  hm2:  (2 pi^2 / 3) hm2 tau
    drift          D:  D^2 tau^2 / 2

These are Allan *variances*; :func:`adev_theory` is the square root of their sum.

:func:`corrected_pps_adev` is the Allan deviation of a GNSS receiver's qErr-corrected 1PPS error (white
noise plus Gauss-Markov terms), from the autocovariance form of NIST SP 1065 eq. (7).
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.models.oscillator import PowerLaw
from chronofuse.models.receiver_model import ReceiverModel
from chronofuse.validation import check_array, check_scalar

__all__ = ["avar_components", "adev_theory", "corrected_pps_adev"]


def avar_components(h: PowerLaw, tau_s, rate_hz: float, drift_per_s: float = 0.0) -> dict[str, np.ndarray]:
    """Allan variance of each noise term at ``tau_s``.

    Parameters
    ----------
    h : PowerLaw
        One-sided ``S_y(f)`` coefficients.
    tau_s : array of shape (k,) (or a scalar)
        Averaging times, s (> 0).
    rate_hz : float
        Sample rate; ``f_h = rate_hz / 2``.
    drift_per_s : float
        Linear fractional-frequency drift ``D``, 1/s.

    Returns
    -------
    dict
        Keys ``"h2", "h1", "h0", "hm1", "hm2", "drift"``, each an array shaped like ``tau_s``.
    """
    if not isinstance(h, PowerLaw):
        raise TypeError(f"h == {h!r}, must be a PowerLaw")
    tau = check_array(tau_s, "tau_s", ndim=(0, 1))
    if np.any(tau <= 0):
        raise ValueError(f"tau_s == {tau.tolist()}, must be > 0")
    check_scalar(rate_hz, "rate_hz", min_val=0.0, include_min=False)
    check_scalar(drift_per_s, "drift_per_s")
    f_h = rate_hz / 2.0
    four_pi2 = 4.0 * math.pi**2
    return {
        "h2": 3.0 * f_h * h.h2 / (four_pi2 * tau**2),
        "h1": (1.038 + 3.0 * np.log(2.0 * math.pi * f_h * tau)) * h.h1 / (four_pi2 * tau**2),
        "h0": h.h0 / (2.0 * tau),
        "hm1": np.full_like(tau, 2.0 * math.log(2.0) * h.hm1),
        "hm2": (2.0 * math.pi**2 / 3.0) * h.hm2 * tau,
        "drift": drift_per_s**2 * tau**2 / 2.0,
    }


def adev_theory(h: PowerLaw, tau_s, rate_hz: float, drift_per_s: float = 0.0) -> np.ndarray:
    """Theoretical Allan deviation ``sqrt(sum of avar_components)``, shaped like ``tau_s``."""
    return np.sqrt(sum(avar_components(h, tau_s, rate_hz, drift_per_s).values()))


def corrected_pps_adev(model: ReceiverModel, tau_s, dt_s: float = 1.0) -> np.ndarray:
    """Theoretical ADEV of a receiver's qErr-corrected 1PPS error ``e`` (no outliers, jumps or outages).

    ``tau_s`` (k,) must be whole multiples ``n dt_s``; returns (k,). For stationary ``e`` with
    autocovariance ``R``, ``AVAR(n dt) = [6 R(0) - 8 R(n) + 2 R(2n)] / (2 n^2 dt^2)`` (the expectation
    of NIST SP 1065 eq. (7)); here ``R(0)`` holds the white variance
    ``sigma_w^2 exp(2 gdop_log_sigma^2)`` (the GDOP gain is log-normal) and each Gauss-Markov term adds
    ``sigma^2 exp(-n dt / tau)`` (:mod:`chronofuse.models.receiver`). This is the GNSS-reference floor a
    disciplined oscillator can reach.
    """
    if not isinstance(model, ReceiverModel):
        raise TypeError(f"model == {model!r}, must be a ReceiverModel")
    tau_s = np.asarray(tau_s, dtype=np.float64)
    n = np.rint(tau_s / dt_s)
    if tau_s.ndim != 1 or np.any(n < 1) or np.any(np.abs(n * dt_s - tau_s) > 1e-9 * tau_s):
        raise ValueError(f"tau_s == {tau_s}, must be a 1-D array of whole multiples of dt_s == {dt_s}")
    white_var = model.white_sigma_s**2 * np.exp(2.0 * model.gdop_log_sigma**2)

    def autocov(lag):
        return (np.where(lag == 0, white_var, 0.0)
                + model.multipath_sigma_s**2 * np.exp(-lag * dt_s / model.multipath_tau_s)
                + model.wander_sigma_s**2 * np.exp(-lag * dt_s / model.wander_tau_s))

    return np.sqrt((6.0 * autocov(0.0 * n) - 8.0 * autocov(n) + 2.0 * autocov(2.0 * n)) / (2.0 * tau_s**2))
