"""Noise and impairments of a two-way radio link (the swarm paper's Table 1, and what a real link adds).

* TOA noise (the paper's Table 1, SNR 4..20 dB in 2 dB steps): sigma 2.5 .. 0.45 ns, interpolated linearly in
  dB; outside the table its end values (per exchange, when the SNR falls with range). The Cramér–Rao
  alternative is ``sigma_TOA = 1 / (2 pi beta sqrt(2 SNR))`` for RMS bandwidth ``beta`` (Kay,
  *Fundamentals of Statistical Signal Processing: Estimation*, 1993, example 3.13, ``2E/N0 = 2 SNR``).
* Doppler (the paper's Table 1): carrier-frequency noise 190 .. 30 Hz per one-way estimate; the two-way velocity
  ``v = -c (f_up + f_down) / (2 f0)`` (the paper's eq. 12: the clocks' frequency offset cancels in the sum) has
  sigma ``c sigma_f / (sqrt(2) f0)``.
* SNR falling with range: free-space spreading, ``SNR(R) = SNR_ref - 20 log10(R / R_ref)`` (Friis), when
  a reference range is given.
* NLOS and multipath outliers: with probability ``p`` a time of arrival is late by an exponential excess
  delay of mean ``mu`` (the reflected path is always longer), each leg independently.
* Burst packet loss: the Gilbert–Elliott two-state chain (Gilbert, Bell Syst. Tech. J. 39, 1960) with
  stationary loss fraction ``p`` and mean burst length ``L`` exchanges: ``P(bad -> good) = 1/L``,
  ``P(good -> bad) = p / (L (1 - p))``.
"""

from __future__ import annotations

import math

import numpy as np

from chronofuse.constants import SPEED_OF_LIGHT_M_PER_S as C
from chronofuse.validation import InputError, check_choice, check_scalar

__all__ = ["SNR_TABLE_DB", "TOA_SIGMA_TABLE_S", "DOPPLER_SIGMA_TABLE_HZ", "TOA_MODELS", "toa_sigma_s",
           "toa_sigma_array_s", "doppler_sigma_hz", "velocity_sigma_array_m_s", "snr_at_range_db",
           "burst_loss", "nlos_excess_s"]

#: The swarm paper's Table 1: SNR grid, dB.
SNR_TABLE_DB = np.array([4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0])
#: The swarm paper's Table 1: TOA estimation error sigma at each SNR, s.
TOA_SIGMA_TABLE_S = np.array([2.5, 2.0, 1.6, 1.25, 1.0, 0.8, 0.6, 0.5, 0.45]) * 1e-9
#: The swarm paper's Table 1: carrier-frequency (Doppler) noise n_i, n_r at each SNR, Hz.
DOPPLER_SIGMA_TABLE_HZ = np.array([190.0, 152.0, 121.0, 96.0, 76.0, 61.0, 48.0, 36.0, 30.0])

TOA_MODELS = ("table", "crb", "none")


def _in_table(snr_db: float, what: str) -> float:
    check_scalar(snr_db, "snr_db")
    if not SNR_TABLE_DB[0] <= snr_db <= SNR_TABLE_DB[-1]:
        raise InputError(
            f"{{snr_db}} == {snr_db}, must be within [{SNR_TABLE_DB[0]:g}, {SNR_TABLE_DB[-1]:g}] dB for the paper's {what} "
            "table (use the Cramér-Rao TOA model for other SNRs)", fields=("snr_db",))
    return float(snr_db)


def toa_sigma_s(snr_db: float, model: str = "table", rms_bandwidth_hz: float = 28.47e6) -> float:
    """TOA noise sigma, s, at ``snr_db``: the paper's table (interpolated), the Cramér–Rao form, or
    ``"none"`` (noiseless timestamps, for truth checks).

    The default RMS bandwidth makes the Cramér–Rao form give the table's 1.25 ns at 10 dB.
    """
    check_choice(model, "toa_model", TOA_MODELS)
    if model == "none":
        return 0.0
    if model == "table":
        return float(np.interp(_in_table(snr_db, "TOA"), SNR_TABLE_DB, TOA_SIGMA_TABLE_S))
    check_scalar(snr_db, "snr_db")
    check_scalar(rms_bandwidth_hz, "rms_bandwidth_hz", min_val=0.0, include_min=False)
    snr = 10.0 ** (snr_db / 10.0)
    return 1.0 / (2.0 * math.pi * rms_bandwidth_hz * math.sqrt(2.0 * snr))


def toa_sigma_array_s(snr_db, model: str = "table", rms_bandwidth_hz: float = 28.47e6) -> np.ndarray:
    """TOA sigma, s, for an array of per-exchange SNRs (NaN stays NaN); the table clamps at its ends."""
    snr = np.asarray(snr_db, dtype=np.float64)
    if model == "none":
        return np.where(np.isnan(snr), np.nan, 0.0)
    if model == "table":
        return np.interp(snr, SNR_TABLE_DB, TOA_SIGMA_TABLE_S)
    return 1.0 / (2.0 * math.pi * rms_bandwidth_hz * np.sqrt(2.0 * 10.0 ** (snr / 10.0)))


def doppler_sigma_hz(snr_db: float) -> float:
    """One-way carrier-frequency noise sigma, Hz, at ``snr_db`` (the paper's Table 1, interpolated)."""
    return float(np.interp(_in_table(snr_db, "Doppler"), SNR_TABLE_DB, DOPPLER_SIGMA_TABLE_HZ))


def velocity_sigma_array_m_s(snr_db, carrier_hz: float) -> np.ndarray:
    """Two-way Doppler velocity sigma, m/s, ``c sigma_f / (sqrt(2) f0)``, per exchange (table clamped)."""
    return C * np.interp(np.asarray(snr_db, dtype=np.float64), SNR_TABLE_DB, DOPPLER_SIGMA_TABLE_HZ) / (
        math.sqrt(2.0) * carrier_hz)


def snr_at_range_db(snr_ref_db: float, range_m, reference_range_m: float | None, min_range_m: float = 100.0):
    """SNR per exchange, dB: constant when ``reference_range_m`` is None, else free-space spreading
    ``snr_ref - 20 log10(R / R_ref)`` with R held at ``min_range_m`` or more."""
    r = np.asarray(range_m, dtype=np.float64)
    if reference_range_m is None:
        return np.full(r.shape, float(snr_ref_db))
    return snr_ref_db - 20.0 * np.log10(np.maximum(r, min_range_m) / reference_range_m)


def burst_loss(uniform: np.ndarray, loss_fraction: float, burst_mean: float) -> np.ndarray:
    """Lost exchanges (bool, shape of ``uniform`` (trials, steps)) from the Gilbert–Elliott chain (module
    docstring); ``uniform`` are U[0, 1) draws, the first column also draws the starting state."""
    lost = np.zeros(uniform.shape, dtype=bool)
    if loss_fraction <= 0.0:
        return lost
    p_leave_bad = 1.0 / burst_mean
    p_enter_bad = loss_fraction / (burst_mean * (1.0 - loss_fraction))
    lost[:, 0] = uniform[:, 0] < loss_fraction
    for k in range(1, uniform.shape[1]):
        lost[:, k] = np.where(lost[:, k - 1], uniform[:, k] >= p_leave_bad, uniform[:, k] < p_enter_bad)
    return lost


def nlos_excess_s(uniform: np.ndarray, exponential: np.ndarray, probability: float, mean_excess_s: float):
    """Excess delays, s (>= 0): ``mean_excess_s * exponential`` where ``uniform < probability``, else 0."""
    if probability <= 0.0:
        return np.zeros(uniform.shape)
    return np.where(uniform < probability, mean_excess_s * exponential, 0.0)
